# cmake -DFILES="a.hpp;b.hpp" -P harden_decode.cmake
#
# LCM 1.3.1's generated C++ decoders trust length fields before checking them
# against the buffer: a string length <= 0 makes `assign(p, len - 1)` copy
# gigabytes, and an array count is resized to before its bytes are read (a
# claimed 2^31 elements allocates first and fails after). This rewrites the
# generated code so that both are checked against what is left of the buffer
# first; a lying message then simply fails to decode.
foreach(f ${FILES})
  file(READ ${f} text)
  # Strings: the length includes the NUL, so it is at least 1.
  string(REGEX REPLACE "if\\(([A-Za-z0-9_]+) > maxlen - pos\\) return -1;"
         "if(\\1 <= 0 || \\1 > maxlen - pos) return -1;" text "${text}")
  # The NUL that ends a string is part of the encoding: a message whose
  # terminator is something else does not decode (it would not encode back
  # to the same bytes, and a checksum over the re-encoding would miss it).
  string(REGEX REPLACE "(this->[A-Za-z0-9_]+(\\[a0\\])?\\.assign\\(\\(\\(const char\\*\\)buf\\) \\+ offset \\+ pos, ([A-Za-z0-9_]+) - +1\\);)"
         "if(((const char*)buf)[offset + pos + \\3 - 1] != '\\\\0') return -1;\n    \\1" text "${text}")
  # LCM strings are C strings: one with a NUL inside would not encode back
  # (the encoder measures with strlen), so it does not decode either.
  string(REGEX REPLACE "(this->[A-Za-z0-9_]+(\\[a0\\])?)(\\.assign\\(\\(\\(const char\\*\\)buf\\) \\+ offset \\+ pos, [A-Za-z0-9_]+ - +1\\);)"
         "\\1\\3 if(\\1.find('\\\\0') != std::string::npos) return -1;" text "${text}")
  # Arrays: every element takes at least one byte of what is left ...
  string(REGEX REPLACE "([ ]*)(this->[A-Za-z0-9_]+(\\[[a-z0-9]+\\])?\\.resize\\(this->([A-Za-z0-9_]+)\\);)"
         "\\1if(this->\\4 < 0 || this->\\4 > maxlen - pos) return -1;\n\\1\\2" text "${text}")
  # ... except the outer dimension of a multi-dimensional array (a resize
  # followed by a loop over it), whose rows may be empty: only the sign is
  # checked there, as for arrays of strings and structs (decoded in a loop
  # too). The message contract keeps all those counts int8/int16, so the
  # allocation a lie can cause is bounded by the type.
  string(REGEX REPLACE
         "if\\(this->([A-Za-z0-9_]+) < 0 \\|\\| this->[A-Za-z0-9_]+ > maxlen - pos\\) return -1;(\n[ ]*this->[A-Za-z0-9_]+\\.resize\\(this->[A-Za-z0-9_]+\\);\n[ ]*for \\(int a)"
         "if(this->\\1 < 0) return -1;\\2" text "${text}")
  file(WRITE ${f} "${text}")
endforeach()
