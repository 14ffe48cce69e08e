#include "acquire/csv_source.h"

#include <cmath>

#include "common/clock.h"
#include "common/log.h"

namespace imuqual::acquire {

CsvSource::CsvSource(CsvSourceOptions options, std::unique_ptr<std::ifstream> file)
    : options_(std::move(options)), file_(std::move(file)) {}

Result<std::unique_ptr<CsvSource>> CsvSource::Open(const CsvSourceOptions& options) {
  if (!(options.rate_hz > 0) || !std::isfinite(options.rate_hz)) {
    return Status::InvalidArgument("csv source " + options.path + ": rate must be > 0 Hz");
  }
  if (options.axes.empty()) return Status::InvalidArgument("csv source " + options.path + ": no axes");
  if (!std::isfinite(options.scale) || options.scale == 0) {
    return Status::InvalidArgument("csv source " + options.path + ": scale must be finite and non-zero");
  }
  auto file = std::make_unique<std::ifstream>(options.path);
  if (!*file) return Status::IoError("cannot read " + options.path);
  std::unique_ptr<CsvSource> s(new CsvSource(options, std::move(file)));
  for (double f : options.axis_factors) {
    if (!std::isfinite(f)) {
      return Status::InvalidArgument("csv source " + options.path + ": an axis factor is not finite");
    }
  }
  std::vector<std::string> wanted;
  for (size_t a = 0; a < options.axes.size(); ++a) {
    const bool own = a < options.axis_columns.size() && !options.axis_columns[a].empty();
    wanted.push_back(own ? options.axis_columns[a] : options.axes[a].name());
  }
  if (!options.counter_column.empty()) wanted.push_back(options.counter_column);
  if (!options.time_column.empty()) {
    s->time_index_ = static_cast<int>(wanted.size());
    wanted.push_back(options.time_column);
  }
  if (!options.temperature_column.empty()) {
    s->temperature_index_ = static_cast<int>(wanted.size());
    wanted.push_back(options.temperature_column);
  }
  s->start_utime_ = NowUtime();
  std::ifstream* in = s->file_.get();
  s->reader_ = std::make_unique<NumericRowReader>(
      [in]() -> std::optional<std::string> {
        std::string line;
        if (!std::getline(*in, line)) return std::nullopt;
        return line;
      },
      options.path, wanted);
  // The axes' columns come first in `wanted`: a bad cell there is an invalid
  // sample of its axis (counted per axis downstream, judged by the plan's
  // invalid_fraction), never the end of the unit's run.
  s->reader_->ReadNonNumbersAsInvalid(options.axes.size());
  IMUQUAL_RETURN_IF_ERROR(s->reader_->Start());
  // A header without rows is no recording, as an empty file is none: it
  // must not become a complete run of 0 samples. The first row is read now
  // and delivered by the first Read().
  Result<bool> first = s->reader_->Next(&s->row_);
  if (!first.ok()) return first.status();
  for (const std::string& w : s->reader_->TakeWarnings()) LogWarning("csv source " + w);
  if (!*first) return Status::InvalidArgument(options.path + ": a header but no samples");
  s->row_pending_ = true;
  s->info_.axes = options.axes;
  s->info_.nominal_rate_hz = options.rate_hz;
  s->info_.description = "csv:" + options.path;
  // Its length for progress: the file's non-empty lines but the header, at
  // the nominal rate (a second pass over the file; about, not exact: a
  // comment line counts).
  if (options.rate_hz > 0) {
    std::ifstream count(options.path, std::ios::binary);
    int64_t rows = 0;
    bool blank = true;
    char buf[1 << 16];
    while (count.read(buf, sizeof buf) || count.gcount() > 0) {
      for (std::streamsize i = 0; i < count.gcount(); ++i) {
        if (buf[i] == '\n') {
          rows += !blank;
          blank = true;
        } else if (buf[i] != '\r' && buf[i] != ' ') {
          blank = false;
        }
      }
    }
    rows += !blank;
    s->info_.planned_s = static_cast<double>(std::max<int64_t>(rows - 1, 0)) / options.rate_hz;
  }
  return s;
}

void CsvSource::Stop() {
  done_ = true;  // a Read() after all would find the end
  have_row_ = row_pending_ = false;
  reader_.reset();  // it reads from file_
  file_.reset();
}

Result<int> CsvSource::Read(int max_samples, SampleBlock* block) {
  const size_t axes = options_.axes.size();
  block->samples.assign(axes, {});
  block->flags.clear();
  block->temperature_c.reset();
  double temperature_sum = 0;
  int temperatures = 0;
  int n = 0;
  while (n < max_samples && !done_) {
    if (!have_row_) {
      if (row_pending_) {
        row_pending_ = false;
      } else {
        Result<bool> more = reader_->Next(&row_);
        if (!more.ok()) return more.status();
        for (const std::string& w : reader_->TakeWarnings()) LogWarning("csv source " + w);
        if (!*more) {
          done_ = true;
          break;
        }
      }
      if (options_.counter_column.empty()) {
        row_counter_ = next_index_++;
      } else {
        const double c = row_[axes];
        if (!std::isfinite(c) || c != std::floor(c) || c < 0 || c > 9e15) {
          return Status::InvalidArgument(options_.path + ":" + std::to_string(reader_->line()) +
                                         ": counter '" + options_.counter_column +
                                         "' must be a non-negative integer");
        }
        row_counter_ = static_cast<int64_t>(c);
        if (row_counter_ <= last_counter_) {
          return Status::InvalidArgument(options_.path + ":" + std::to_string(reader_->line()) +
                                         ": counter goes backwards (" + std::to_string(row_counter_) +
                                         " after " + std::to_string(last_counter_) + ")");
        }
      }
      have_row_ = true;
    }
    // A block holds consecutive samples: a counter jump starts the next one.
    if (n > 0 && row_counter_ != block->first_sample + n) break;
    if (n == 0) {
      block->first_sample = row_counter_;
      if (time_index_ >= 0) {
        const double t = row_[time_index_];
        if (!std::isfinite(t) || std::abs(t) > 1e10) {
          return Status::InvalidArgument(options_.path + ":" + std::to_string(reader_->line()) +
                                         ": time '" + options_.time_column + "' must be a number of seconds");
        }
        block->first_sample_utime = start_utime_ + std::llround(t * 1e6);
      }
    }
    for (size_t a = 0; a < axes; ++a) {
      const double factor = a < options_.axis_factors.size() && options_.axis_factors[a] != 0
                                ? options_.axis_factors[a]
                                : options_.scale;
      block->samples[a].push_back(static_cast<float>(row_[a] * factor));
    }
    if (temperature_index_ >= 0 && std::isfinite(row_[temperature_index_])) {
      temperature_sum += row_[temperature_index_];
      ++temperatures;
    }
    last_counter_ = row_counter_;
    have_row_ = false;
    ++n;
  }
  if (temperatures > 0) block->temperature_c = static_cast<float>(temperature_sum / temperatures);
  return n;
}

}  // namespace imuqual::acquire
