// Replay of a stored run from an archive's raw chunks: the same float32
// samples at the same device counters, with their flags, temperatures and
// arrival times, so a stored run can be re-run through a station (another
// plan, another analysis build, an archive on another machine). Missing
// chunks of the original stay gaps. Reads the archive page by page: any
// length. Not thread-safe.
#ifndef IMUQUAL_ACQUIRE_ARCHIVE_SOURCE_H_
#define IMUQUAL_ACQUIRE_ARCHIVE_SOURCE_H_

#include <deque>
#include <memory>
#include <string>

#include "acquire/source.h"
#include "store/archive.h"
#include "store/chunk_codec.h"

namespace imuqual::acquire {

class ArchiveSource : public SampleSource {
 public:
  // Opens `db_path` read-only and finds `run_id`; errors name both.
  static Result<std::unique_ptr<ArchiveSource>> Open(const std::string& db_path,
                                                     const std::string& run_id);
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;
  // Closes the archive.
  void Stop() override;

 private:
  struct Pending {
    int64_t first_sample;
    int64_t sample_utime;  // of samples[*][0]; 0 once the chunk has been split
    std::optional<float> temperature_c;
    store::ChunkData data;
    int offset = 0;        // samples already delivered
  };
  ArchiveSource() = default;
  Status Fill();  // loads the next page of chunks when none is pending

  std::unique_ptr<store::Archive> archive_;
  std::string run_id_;
  int64_t run_key_ = 0;
  int64_t next_seq_ = 0;
  int64_t last_seq_ = -1;
  int64_t end_counter_ = -1;  // after the last delivered sample
  SourceInfo info_;
  std::deque<Pending> pending_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_ARCHIVE_SOURCE_H_
