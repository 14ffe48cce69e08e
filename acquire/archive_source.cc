#include "acquire/archive_source.h"

#include <algorithm>

#include "store/chunk_codec.h"

namespace imuqual::acquire {
namespace {
constexpr int64_t kChunksPerPage = 64;
}  // namespace

Result<std::unique_ptr<ArchiveSource>> ArchiveSource::Open(const std::string& db_path,
                                                           const std::string& run_id) {
  if (run_id.empty()) {
    return Status::InvalidArgument("archive source " + db_path + ": name the run (run=RUN_ID)");
  }
  auto archive = store::Archive::Open(db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) return archive.status();
  auto run = (*archive)->LoadRun(run_id);
  if (!run.ok()) return run.status().WithContext("archive source " + db_path);
  auto key = (*archive)->FindRunKey(run_id);
  if (!key.ok()) return key.status();
  if (!key->has_value()) return Status::NotFound("archive source " + db_path + ": no run " + run_id);
  std::unique_ptr<ArchiveSource> s(new ArchiveSource());
  s->archive_ = std::move(*archive);
  s->run_id_ = run_id;
  s->run_key_ = **key;
  s->last_seq_ = run->last_seq;
  for (const store::AxisInfo& a : run->axes) {
    pb::Axis axis;
    axis.set_name(a.name);
    axis.set_kind(a.kind);
    s->info_.axes.push_back(axis);
  }
  s->info_.nominal_rate_hz = run->nominal_rate_hz;
  s->info_.description = "archive:" + db_path + ",run=" + run_id;
  s->info_.truth = run->truth;
  if (run->end_sample > run->first_sample && run->first_sample >= 0 && run->nominal_rate_hz > 0) {
    s->info_.planned_s =
        static_cast<double>(run->end_sample - run->first_sample) / run->nominal_rate_hz;
  }
  if (s->info_.axes.empty() || !(s->info_.nominal_rate_hz > 0)) {
    return Status::Corruption("archive source " + db_path + ": run " + run_id +
                              " has no axes or no rate");
  }
  return s;
}

Status ArchiveSource::Fill() {
  while (pending_.empty() && next_seq_ <= last_seq_) {
    const int64_t last = std::min(last_seq_, next_seq_ + kChunksPerPage - 1);
    Status st = archive_->ForEachChunk(
        run_key_,
        [this](const store::ChunkRecord& c) -> Status {
          auto data = store::DecodeChunk(c.data, c.codec);
          if (!data.ok()) return data.status().WithContext("run " + run_id_ + " seq " + std::to_string(c.seq));
          if (static_cast<size_t>(data->num_axes) != info_.axes.size()) {
            return Status::Corruption("run " + run_id_ + " seq " + std::to_string(c.seq) + " has " +
                                      std::to_string(data->num_axes) + " axes");
          }
          if (data->num_samples == 0) return Status::Ok();
          Pending p{c.first_sample, c.sample_utime, std::nullopt, std::move(*data), 0};
          if (c.temperature_c) p.temperature_c = static_cast<float>(*c.temperature_c);
          pending_.push_back(std::move(p));
          return Status::Ok();
        },
        next_seq_, last);
    IMUQUAL_RETURN_IF_ERROR(st);
    next_seq_ = last + 1;
  }
  return Status::Ok();
}

Result<int> ArchiveSource::Read(int max_samples, SampleBlock* block) {
  block->samples.assign(info_.axes.size(), {});
  block->flags.clear();
  block->temperature_c.reset();
  block->first_sample_utime = 0;
  int n = 0;
  while (n < max_samples) {
    IMUQUAL_RETURN_IF_ERROR(Fill());
    if (pending_.empty()) break;
    Pending& p = pending_.front();
    const int64_t counter = p.first_sample + p.offset;
    // A chunk that overlaps what was delivered (the original's counter went
    // back) is skipped, as the live analysis rejected it.
    if (end_counter_ >= 0 && counter < end_counter_) {
      pending_.pop_front();
      continue;
    }
    if (n > 0 && counter != block->first_sample + n) break;  // a gap: the next block
    // A chunk with its own arrival time starts a block, so the replayed run
    // has every arrival time the original had.
    if (n > 0 && p.offset == 0 && p.sample_utime > 0) break;
    if (n == 0) {
      block->first_sample = counter;
      block->first_sample_utime = p.offset == 0 ? p.sample_utime : 0;
      block->temperature_c = p.temperature_c;
    }
    const int take = std::min(max_samples - n, p.data.num_samples - p.offset);
    for (size_t a = 0; a < info_.axes.size(); ++a) {
      for (int i = 0; i < take; ++i) block->samples[a].push_back(p.data.at(static_cast<int>(a), p.offset + i));
    }
    for (const store::SampleFlag& f : p.data.flags) {
      if (f.sample >= p.offset && f.sample < p.offset + take) {
        block->flags.push_back({n + f.sample - p.offset, f.axis, f.bits});
      }
    }
    n += take;
    p.offset += take;
    end_counter_ = counter + take;
    if (p.offset == p.data.num_samples) pending_.pop_front();
  }
  return n;
}

void ArchiveSource::Stop() {
  pending_.clear();
  next_seq_ = last_seq_ + 1;  // a Read() after all would find the end
  archive_.reset();
}

}  // namespace imuqual::acquire
