// The store's ingest path on one thread, without the bus: what the store's
// writer thread does for each raw batch, from the bytes as they arrive to a
// committed row: LCM decode of rate_batch_t, the chunk codec (records.h
// ChunkFromBatch, each axis's scale carried from chunk to chunk as the store
// does), INSERT into raw_chunks, COMMIT every `batches per transaction` (WAL,
// synchronous=NORMAL, automatic checkpoints included). The store has one
// writer thread, so this is its ceiling in values (samples x axes) per
// second; the station's figure (scripts/bench station) adds the bus.
//
// Batches: 16 simulated tactical units (3 gyro + 3 accel axes, 1000 Hz) in
// the batch size a paced source uses on one host (334 samples, 8 KB; a
// time-warped one sends twice that), unit after unit as they come on the
// bus. Data: float32 noise (quantize=0, codec 2), and a
// 16-bit ADC with an LSB of 0.005 deg/s or m/s^2 (tens of LSB of gyro
// noise, codec 3).
// Transactions: 64 batches (a writer behind its queue takes up to 4000) and
// 1 (an idle store commits each batch as it comes).
// Also the cost of schema 7's tamper evidence: the BLAKE2b-256 digest the
// store computes for each chunk it writes (ChunkDigestCost), and finalising
// and signing a run of 20000 chunks (Finalize/Sign: from the chunk digests'
// covering index) against reading its samples back (Finalize/ReadBack).
// Usage: store_ingest_bench --db SCRATCH.db [benchmark flags]; the file is
// replaced.
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "acquire/acquire_service.h"
#include "acquire/source_spec.h"
#include "bench/bench_summary.h"
#include "common/keys.h"
#include "common/lcm_bus.h"
#include "imuqual/rate_batch_t.hpp"
#include "store/archive.h"
#include "store/canonical.h"
#include "store/records.h"

namespace {

using namespace imuqual;

constexpr int kUnits = 16;
constexpr int kBatchesPerUnit = 60;  // 20 s of each unit per iteration
constexpr int kBatchSamples = 334;   // acquire's 8 KB batch of 6 axes
constexpr double kRateHz = 1000;

std::string g_db;

struct Variant {
  std::string name;
  std::string source_options;  // appended to sim:tactical,index=N
};

const Variant kFloat32{"float32", ",quantize=0"};
const Variant kInt16{"int16", ",lsb=0.005,bits=16"};

// Encoded messages, unit after unit, seqs 0..kBatchesPerUnit-1 per unit.
struct Workload {
  std::vector<std::vector<uint8_t>> messages;
  std::vector<store::RunInfo> runs;
  int64_t values = 0;
};

Workload MakeWorkload(const Variant& v) {
  Workload w;
  std::vector<std::unique_ptr<acquire::SampleSource>> sources;
  for (int u = 0; u < kUnits; ++u) {
    auto spec = acquire::ParseSourceSpec("sim:tactical,index=" + std::to_string(u) + v.source_options);
    acquire::SourceDefaults d;
    d.lot = "BENCH";
    d.rate_hz = kRateHz;
    d.duration_s = kBatchesPerUnit * kBatchSamples / kRateHz;
    auto source = acquire::MakeSource(*spec, d);
    if (!source.ok()) {
      std::fprintf(stderr, "store_ingest_bench: %s\n", source.status().message().c_str());
      std::exit(2);
    }
    store::RunInfo info;
    info.run_id = "BENCH-" + v.name + "-U" + std::to_string(u);
    info.serial = "U" + std::to_string(u);
    info.lot = "BENCH";
    info.station = "bench";
    info.nominal_rate_hz = kRateHz;
    for (const pb::Axis& a : (*source)->info().axes) info.axes.push_back({a.name(), a.kind()});
    w.runs.push_back(info);
    sources.push_back(std::move(*source));
  }
  for (int b = 0; b < kBatchesPerUnit; ++b) {
    for (int u = 0; u < kUnits; ++u) {
      acquire::SampleBlock block;
      auto n = sources[static_cast<size_t>(u)]->Read(kBatchSamples, &block);
      if (!n.ok() || *n <= 0) {
        std::fprintf(stderr, "store_ingest_bench: the simulated unit ended early\n");
        std::exit(2);
      }
      imuqual::rate_batch_t msg;
      msg.host_utime = block.first_sample_utime;
      msg.run_id = w.runs[static_cast<size_t>(u)].run_id;
      msg.unit_serial = w.runs[static_cast<size_t>(u)].serial;
      msg.seq = b;
      msg.nominal_rate_hz = kRateHz;
      msg.num_axes = static_cast<int8_t>(block.samples.size());
      for (const store::AxisInfo& a : w.runs[static_cast<size_t>(u)].axes) {
        msg.axis_names.push_back(a.name);
        msg.axis_kinds.push_back(a.kind == pb::ACCEL ? imuqual::rate_batch_t::KIND_ACCEL
                                                     : imuqual::rate_batch_t::KIND_GYRO);
      }
      acquire::MoveBlockIntoBatch(std::move(block), &msg);
      std::vector<uint8_t> bytes;
      if (Status st = EncodeMessage(msg, &bytes); !st.ok()) {
        std::fprintf(stderr, "store_ingest_bench: %s\n", st.message().c_str());
        std::exit(2);
      }
      w.messages.push_back(std::move(bytes));
      w.values += int64_t{*n} * msg.num_axes;
    }
  }
  return w;
}

void Check(const Status& st, benchmark::State& state) {
  if (!st.ok()) state.SkipWithError(st.message().c_str());
}

// range(0): batches per transaction; range(1): 0 float32, 1 int16.
void Ingest(benchmark::State& state) {
  const int per_transaction = static_cast<int>(state.range(0));
  const Variant& variant = state.range(1) == 0 ? kFloat32 : kInt16;
  static std::map<std::string, Workload> workloads;
  auto [it, fresh] = workloads.try_emplace(variant.name);
  if (fresh) it->second = MakeWorkload(variant);
  const Workload& w = it->second;

  for (const char* suffix : {"", "-wal", "-shm"}) ::unlink((g_db + suffix).c_str());
  auto archive_or = store::Archive::Open(g_db, store::Archive::Mode::kWrite);
  if (!archive_or.ok()) {
    state.SkipWithError(archive_or.status().message().c_str());
    return;
  }
  store::Archive& archive = **archive_or;
  std::map<std::string, int64_t> keys;
  std::map<std::string, std::vector<double>> scales;
  Check(archive.Begin(), state);
  for (const store::RunInfo& info : w.runs) keys[info.run_id] = *archive.UpsertRun(info);
  Check(archive.Commit(), state);

  int64_t round = 0, values = 0;
  for (auto _ : state) {
    // Every iteration appends new seqs, as a soak goes on.
    const int64_t seq_offset = round++ * kBatchesPerUnit;
    int in_transaction = 0;
    for (const std::vector<uint8_t>& bytes : w.messages) {
      if (in_transaction == 0) Check(archive.Begin(), state);
      imuqual::rate_batch_t b;
      Check(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &b), state);
      b.seq += seq_offset;
      bool inserted = false;
      Check(archive.InsertChunk(keys[b.run_id], store::ChunkFromBatch(b, &scales[b.run_id]), &inserted),
            state);
      if (++in_transaction == per_transaction) {
        Check(archive.Commit(), state);
        in_transaction = 0;
      }
    }
    if (in_transaction > 0) Check(archive.Commit(), state);
    values += w.values;
  }
  state.counters["values_per_s"] = benchmark::Counter(static_cast<double>(values), benchmark::Counter::kIsRate);
  state.counters["values_per_iteration"] = static_cast<double>(w.values);
}
BENCHMARK(Ingest)
    ->Args({64, 0})
    ->Args({64, 1})
    ->Args({1, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5)
    ->Repetitions(3);

// The digest the store computes for each chunk it writes (schema 7,
// store/canonical.h ChunkDigest: BLAKE2b-256 of the chunk's canonical row),
// over the float32 workload's chunks as the store encodes them.
void ChunkDigestCost(benchmark::State& state) {
  static const Workload w = MakeWorkload(kFloat32);
  std::map<std::string, std::vector<double>> scales;
  std::vector<store::ChunkRecord> chunks;
  for (const std::vector<uint8_t>& bytes : w.messages) {
    imuqual::rate_batch_t b;
    Check(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &b), state);
    chunks.push_back(store::ChunkFromBatch(b, &scales[b.run_id]));
  }
  uint8_t sink = 0;
  for (auto _ : state) {
    for (const store::ChunkRecord& c : chunks) sink ^= store::ChunkDigest(c)[0];
  }
  benchmark::DoNotOptimize(sink);
  state.counters["values_per_iteration"] = static_cast<double>(w.values);
  state.counters["chunks_per_iteration"] = static_cast<double>(chunks.size());
}
BENCHMARK(ChunkDigestCost)->Unit(benchmark::kMillisecond)->Iterations(20)->Repetitions(3);

// Finalising (and signing) one long run: range(0) chunks of the float32
// workload (8 KB each) in one run, then each iteration MarkFinalized (its
// record from the chunk digests' covering index, an Ed25519 signature, the
// chain entry) and COMMIT. Reading the run's samples back, what signing
// without per-chunk digests would need, is ReadBack.
void Finalize(benchmark::State& state, bool read_back) {
  static const Workload w = MakeWorkload(kFloat32);
  const int64_t chunks = state.range(0);
  for (const char* suffix : {"", "-wal", "-shm"}) ::unlink((g_db + suffix).c_str());
  auto archive_or = store::Archive::Open(g_db, store::Archive::Mode::kWrite);
  if (!archive_or.ok()) {
    state.SkipWithError(archive_or.status().message().c_str());
    return;
  }
  store::Archive& archive = **archive_or;
  auto key_pair = GenerateSigningKey("store");
  if (!key_pair.ok()) {
    state.SkipWithError(key_pair.status().message().c_str());
    return;
  }
  Check(archive.SetSigningKey(*key_pair), state);
  Check(archive.Begin(), state);
  store::RunInfo info = w.runs[0];
  info.run_id = "LONG";
  const int64_t key = *archive.UpsertRun(info);
  std::vector<double> scales;
  for (int64_t seq = 0; seq < chunks; ++seq) {
    const std::vector<uint8_t>& bytes = w.messages[static_cast<size_t>(seq) % w.messages.size()];
    imuqual::rate_batch_t b;
    Check(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &b), state);
    b.seq = seq;
    Check(archive.InsertChunk(key, store::ChunkFromBatch(b, &scales), nullptr), state);
    if (seq % 1000 == 999) {
      Check(archive.Commit(), state);
      Check(archive.Begin(), state);
    }
  }
  Check(archive.Commit(), state);
  int64_t bytes_read = 0;
  for (auto _ : state) {
    if (read_back) {
      Check(archive.ForEachChunk(key,
                                 [&](const store::ChunkRecord& c) {
                                   bytes_read += static_cast<int64_t>(c.data.size());
                                   return Status::Ok();
                                 }),
            state);
    } else {
      Check(archive.Begin(), state);
      Check(archive.MarkFinalized(key, 1), state);
      Check(archive.Commit(), state);
    }
  }
  benchmark::DoNotOptimize(bytes_read);
}
BENCHMARK_CAPTURE(Finalize, Sign, false)->Arg(20000)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK_CAPTURE(Finalize, ReadBack, true)
    ->Arg(20000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> args = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--db") == 0 && i + 1 < argc) {
      g_db = argv[++i];
      continue;
    }
    args.push_back(argv[i]);
  }
  if (g_db.empty()) {
    std::fprintf(stderr, "store_ingest_bench: --db SCRATCH.db needed (it is replaced)\n");
    return 2;
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  for (const char* suffix : {"", "-wal", "-shm"}) ::unlink((g_db + suffix).c_str());
  // Values per second from the best iteration of each.
  auto rate = [&](const std::string& name) {
    const double values = reporter.Counter(name, "values_per_iteration");
    return values / reporter.BestRealSeconds(name);
  };
  bench::PrintFigure("store_ingest_samples_per_s", rate("Ingest/64/0/iterations:5/repeats:3"), "samples/s");
  bench::PrintFigure("store_ingest_samples_per_s_int16", rate("Ingest/64/1/iterations:5/repeats:3"),
                     "samples/s");
  bench::PrintFigure("store_ingest_samples_per_s_commit_each", rate("Ingest/1/0/iterations:5/repeats:3"),
                     "samples/s");
  const std::string digest = "ChunkDigestCost/iterations:20/repeats:3";
  bench::PrintFigure(
      "store_chunk_digest_us",
      reporter.BestRealSeconds(digest) * 1e6 / reporter.Counter(digest, "chunks_per_iteration"),
      "us/chunk");
  bench::PrintFigure("store_chunk_digest_values_per_s", rate(digest), "samples/s");
  bench::PrintFigure("store_finalize_sign_20k_chunks_ms",
                     reporter.BestRealSeconds("Finalize/Sign/20000/iterations:5") * 1e3, "ms");
  bench::PrintFigure("store_read_back_20k_chunks_ms",
                     reporter.BestRealSeconds("Finalize/ReadBack/20000/iterations:3") * 1e3, "ms");
  return 0;
}
