// Parsing protobuf text format written by people (test plans, station
// configurations): the first error as "SOURCE:LINE:COLUMN: message", and
// the line of any field, so that validation errors can point at it too.
#ifndef IMUQUAL_PROTO_TEXT_PROTO_H_
#define IMUQUAL_PROTO_TEXT_PROTO_H_

#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <string>
#include <string_view>

#include "common/status.h"

namespace imuqual::pb {

class TextProto {
 public:
  // Parses `text` into `message` (cleared first). The error names `source`.
  Status Parse(std::string_view text, const std::string& source, google::protobuf::Message* message);

  // 1-based line of top-level `field` (its index-th element if repeated),
  // or of `sub` inside that message when given; -1 if unknown.
  int LineOf(const google::protobuf::Descriptor* type, const char* field, int index,
             const char* sub = nullptr) const;

 private:
  google::protobuf::TextFormat::ParseInfoTree tree_;
};

}  // namespace imuqual::pb

#endif  // IMUQUAL_PROTO_TEXT_PROTO_H_
