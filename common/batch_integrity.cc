#include "common/batch_integrity.h"

#include <cstdio>
#include <string>

#include "common/crc32c.h"
#include "common/lcm_bus.h"

namespace imuqual {
namespace {

// crc32c is the last field: an int32, big-endian, the encoding's last bytes.
constexpr size_t kCrcBytes = 4;

uint32_t ChecksumOfEncoding(const std::vector<uint8_t>& bytes) {
  return Crc32c(bytes.data(), bytes.size() - kCrcBytes);
}

std::string Hex(uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", v);
  return text;
}

}  // namespace

Status EncodeSealedBatch(imuqual::rate_batch_t* batch, std::vector<uint8_t>* bytes) {
  batch->crc32c = 0;
  IMUQUAL_RETURN_IF_ERROR(EncodeMessage(*batch, bytes));
  if (bytes->size() < kCrcBytes) return Status::InvalidArgument("rate_batch_t encodes to nothing");
  const uint32_t crc = ChecksumOfEncoding(*bytes);
  batch->crc32c = static_cast<int32_t>(crc);
  uint8_t* tail = bytes->data() + bytes->size() - kCrcBytes;
  tail[0] = static_cast<uint8_t>(crc >> 24);
  tail[1] = static_cast<uint8_t>(crc >> 16);
  tail[2] = static_cast<uint8_t>(crc >> 8);
  tail[3] = static_cast<uint8_t>(crc);
  return Status::Ok();
}

Status VerifyBatch(const imuqual::rate_batch_t& batch) {
  std::vector<uint8_t> bytes;
  Status st = EncodeMessage(batch, &bytes);
  if (!st.ok() || bytes.size() < kCrcBytes) {
    return Status::Corruption("batch of run " + batch.run_id + " seq " + std::to_string(batch.seq) +
                              " does not encode again: damaged");
  }
  const uint32_t computed = ChecksumOfEncoding(bytes);
  const uint32_t carried = static_cast<uint32_t>(batch.crc32c);
  if (computed != carried) {
    return Status::Corruption("batch claiming run '" + batch.run_id + "' seq " +
                              std::to_string(batch.seq) + " is damaged: checksum " + Hex(carried) +
                              ", contents give " + Hex(computed));
  }
  return Status::Ok();
}

}  // namespace imuqual
