# cmake -DOUT=<file.cc> -DPLANS="<a.textproto;b.textproto>" -P embed_plans.cmake
# Writes a .cc that defines BuiltinPlanFiles() with each file's text.
set(body "")
foreach(f ${PLANS})
  get_filename_component(name ${f} NAME_WE)
  file(READ ${f} text)
  string(FIND "${text}" ")imuqual_plan\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${f} contains the raw-string delimiter")
  endif()
  string(APPEND body "      {\"${name}\", R\"imuqual_plan(${text})imuqual_plan\"},\n")
endforeach()
file(WRITE ${OUT}.tmp "// Generated from plans/*.textproto at build time. Do not edit.
#include \"analyze/judge/builtin_plans.h\"

namespace imuqual::judge {

const std::vector<BuiltinPlanFile>& BuiltinPlanFiles() {
  static const std::vector<BuiltinPlanFile> kFiles = {
${body}  };
  return kFiles;
}

}  // namespace imuqual::judge
")
file(COPY_FILE ${OUT}.tmp ${OUT} ONLY_IF_DIFFERENT)
