// End-to-end integrity of raw batches: rate_batch_t.crc32c is the CRC-32C
// of the message's LCM encoding up to that field (the fingerprint and every
// field: run id, serial, seq, counters, axes, samples, flags, temperature,
// times). The sender seals a batch once and publishes those bytes; every
// receiver verifies before it looks at any field, so a batch damaged on the
// way (a flipped bit that got past, or around, the UDP checksum) is never
// analysed or archived. LCM's decoder has checked the lengths already; the
// checksum covers what a length check cannot see.
#ifndef IMUQUAL_COMMON_BATCH_INTEGRITY_H_
#define IMUQUAL_COMMON_BATCH_INTEGRITY_H_

#include <cstdint>
#include <vector>

#include "common/status.h"
#include "imuqual/rate_batch_t.hpp"

namespace imuqual {

// Sets batch->crc32c and writes the sealed encoding into *bytes. Fails if
// the batch does not encode (inconsistent length fields).
Status EncodeSealedBatch(imuqual::rate_batch_t* batch, std::vector<uint8_t>* bytes);

// Ok if batch.crc32c matches its contents; Corruption (naming the run, seq
// and both checksums) otherwise. Receivers call it on the decoded message:
// LCM's encoding is a bijection on what decodes, so re-encoding gives back
// the received bytes.
Status VerifyBatch(const imuqual::rate_batch_t& batch);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_BATCH_INTEGRITY_H_
