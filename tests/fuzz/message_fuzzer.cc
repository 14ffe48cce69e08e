// Fuzzes what arrives from the bus: the first byte picks a message type, the
// rest is decoded exactly as the processes decode it. What decodes goes on
// through the validation the processes apply: a rate batch through the run
// analyzer and the archive's chunk codec, a run announcement through plan
// validation. Nothing may crash, hang or leak; lies must be rejected.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "analyze/judge/plan.h"
#include "analyze/service/run_analyzer.h"
#include "common/lcm_bus.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/allan_curve_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "store/chunk_codec.h"

namespace {

using namespace imuqual;

void CheckBatch(const imuqual::rate_batch_t& b) {
  analyze::RunDescription d;
  d.run_id = b.run_id;
  d.serial = b.unit_serial;
  d.nominal_rate_hz = 100;
  for (int i = 0; i < 3; ++i) d.axes.push_back({"a" + std::to_string(i), pb::GYRO});
  auto analyzer = analyze::RunAnalyzer::Create(d);
  if (!analyzer.ok()) return;
  analyze::BatchView view;
  view.seq = b.seq;
  view.first_sample = b.first_sample;
  view.nominal_rate_hz = b.nominal_rate_hz;
  for (const std::vector<float>& axis : b.samples) view.samples.emplace_back(axis);
  for (int i = 0; i < b.num_flagged; ++i) {
    view.flags.push_back({b.flagged_sample[i], b.flagged_axis[i], b.flagged_bits[i]});
  }
  (void)analyzer->AddBatch(view);
  (void)analyzer->Outcome(true);

  // The archive's codec on what a store would write.
  if (b.num_axes < 1 || b.num_samples < 0) return;
  store::ChunkData c;
  c.num_axes = b.num_axes;
  c.num_samples = b.num_samples;
  for (const std::vector<float>& axis : b.samples) c.samples.insert(c.samples.end(), axis.begin(), axis.end());
  if (c.samples.size() != static_cast<size_t>(c.num_axes) * c.num_samples) return;
  for (int i = 0; i < b.num_flagged; ++i) {
    if (b.flagged_sample[i] < 0 || b.flagged_sample[i] >= b.num_samples || b.flagged_axis[i] < 0 ||
        b.flagged_axis[i] >= b.num_axes) {
      return;
    }
    c.flags.push_back({static_cast<uint16_t>(b.flagged_sample[i]), static_cast<uint8_t>(b.flagged_axis[i]),
                       static_cast<uint8_t>(b.flagged_bits[i])});
  }
  // What the store would archive decodes to the same bits.
  const store::EncodedChunk e = store::EncodeChunkCompact(c);
  auto back = store::DecodeChunk(e.data, e.codec);
  if (!back.ok() || back->samples.size() != c.samples.size() ||
      (!c.samples.empty() &&  // memcmp of no bytes still wants real pointers
       std::memcmp(back->samples.data(), c.samples.data(), c.samples.size() * sizeof(float)) != 0) ||
      back->flags != c.flags) {
    __builtin_trap();
  }
}

template <typename T>
void Decode(const uint8_t* data, size_t size) {
  T msg;
  if (!DecodeExactly(data, static_cast<int>(size), &msg).ok()) return;
  if constexpr (std::is_same_v<T, imuqual::rate_batch_t>) CheckBatch(msg);
  if constexpr (std::is_same_v<T, imuqual::run_t>) {
    pb::TestPlan plan;
    if (plan.ParseFromArray(msg.plan.data(), static_cast<int>(msg.plan.size()))) {
      (void)judge::ValidatePlan(plan);
    }
  }
  // What decoded re-encodes, and decodes back to the same message (LCM's
  // decoder tolerates some byte patterns, e.g. a string terminator that is
  // not NUL, so the bytes themselves need not round-trip).
  std::vector<uint8_t> once, twice;
  if (!EncodeMessage(msg, &once).ok()) __builtin_trap();
  T back;
  if (!DecodeExactly(once.data(), static_cast<int>(once.size()), &back).ok()) __builtin_trap();
  if (!EncodeMessage(back, &twice).ok() || once != twice) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > (1 << 16)) return 0;
  const uint8_t* body = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 8) {
    case 0: Decode<imuqual::rate_batch_t>(body, n); break;
    case 1: Decode<imuqual::run_t>(body, n); break;
    case 2: Decode<imuqual::ack_t>(body, n); break;
    case 3: Decode<imuqual::resend_t>(body, n); break;
    case 4: Decode<imuqual::allan_curve_t>(body, n); break;
    case 5: Decode<imuqual::unit_result_t>(body, n); break;
    case 6: {
      // Archived BLOBs of any codec, damaged: an error, never a crash.
      for (int codec : {store::kCodecRawFloat32, store::kCodecFloatZstd, store::kCodecQuantizedZstd}) {
        (void)store::DecodeChunk({body, n}, codec);
      }
      Decode<imuqual::status_t>(body, n);
      break;
    }
    case 7: Decode<imuqual::decision_t>(body, n); break;
  }
  return 0;
}
