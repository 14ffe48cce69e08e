#include "proto/text_proto.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/tokenizer.h>

#include <string_view>
#include <vector>

#include "common/strings.h"

namespace imuqual::pb {
namespace {

using google::protobuf::FieldDescriptor;

// " (did you mean warmup_s?)" for protobuf's 'Message type "T" has no field
// named "F".' when T has a field close to F; "" otherwise.
std::string FieldSuggestion(const std::string& message) {
  constexpr std::string_view kType = "Message type \"", kField = "has no field named \"";
  const size_t t = message.find(kType), f = message.find(kField);
  if (t == std::string::npos || f == std::string::npos) return "";
  const size_t t0 = t + kType.size(), f0 = f + kField.size();
  const std::string type = message.substr(t0, message.find('"', t0) - t0);
  const std::string field = message.substr(f0, message.find('"', f0) - f0);
  const google::protobuf::Descriptor* d =
      google::protobuf::DescriptorPool::generated_pool()->FindMessageTypeByName(type);
  if (d == nullptr) return "";
  std::vector<std::string> names;
  for (int i = 0; i < d->field_count(); ++i) names.push_back(d->field(i)->name());
  return imuqual::DidYouMean(field, names);
}

// Keeps the first parse error with its 1-based line and column.
class FirstErrorCollector : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override {
    if (first_.empty()) {
      first_ = std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message +
               FieldSuggestion(message);
    }
  }
  const std::string& first() const { return first_; }

 private:
  std::string first_;
};

}  // namespace

Status TextProto::Parse(std::string_view text, const std::string& source,
                        google::protobuf::Message* message) {
  google::protobuf::TextFormat::Parser parser;
  FirstErrorCollector errors;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(&tree_);
  message->Clear();
  if (!parser.ParseFromString(std::string(text), message)) {
    return Status::InvalidArgument(source + ":" +
                                   (errors.first().empty() ? std::string(" cannot parse") : errors.first()));
  }
  return Status::Ok();
}

int TextProto::LineOf(const google::protobuf::Descriptor* type, const char* field, int index,
                      const char* sub) const {
  const FieldDescriptor* fd = type->FindFieldByName(field);
  if (fd == nullptr) return -1;
  const int idx = fd->is_repeated() ? index : -1;
  int line = tree_.GetLocation(fd, idx).line;
  if (sub != nullptr && fd->message_type() != nullptr) {
    const FieldDescriptor* sd = fd->message_type()->FindFieldByName(sub);
    const auto* nested = tree_.GetTreeForNested(fd, idx);
    if (sd != nullptr && nested != nullptr) {
      const int sub_line = nested->GetLocation(sd, sd->is_repeated() ? 0 : -1).line;
      if (sub_line >= 0) line = sub_line;
    }
  }
  return line < 0 ? -1 : line + 1;
}

}  // namespace imuqual::pb
