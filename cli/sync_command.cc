#include "cli/sync_command.h"

#include <cstdio>

#include "common/keys.h"
#include "common/log.h"
#include "common/process_status.h"
#include "store/archive.h"
#include "store/plant_sync.h"

namespace imuqual::cli {
namespace {
constexpr int kExitFailed = 1, kExitUsage = 2, kExitRefused = 3;
}  // namespace

CLI::App* AddSyncCommand(CLI::App& app, SyncOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "sync",
      "ship a station's finalised runs (with their raw samples, curves, measurements, judgement "
      "rounds and signed chain entries) to the plant archive on PostgreSQL");
  cmd->add_option("--db", o->db_path, "the station's archive file")->required();
  cmd->add_option("--to", o->to, "the plant archive: postgresql://...")->required();
  CLI::Option* pubkey = cmd->add_option(
      "--pubkey", o->pubkey_paths,
      "trusted public key of the station's store (store.key.pub) or a trust file, repeatable: "
      "each chain entry's signature is checked before it is shipped, an unsigned one refused");
  cmd->add_flag("--allow-unsigned", o->allow_unsigned,
                "with --pubkey: ship unsigned entries (a store without --sign-key) unchecked")
      ->needs(pubkey);
  cmd->add_option("--batch", o->batch, "chain entries per plant transaction")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--new-archive-of", o->new_archive_of,
                  "STATION: this file is that station's new archive (a rebuilt station): the "
                  "plant moves the station id to it, recorded, and refuses the old archive's "
                  "further runs of it");
  cmd->add_flag("--quiet", o->quiet, "no progress lines");
  cmd->footer(
      "Ships the entries of the station's chain the plant does not hold yet, in order, each "
      "batch in one transaction with the station's cursor: run it as often as you like (again: "
      "nothing inserted), after a week offline it catches up. Each run's record is recomputed "
      "from the rows the plant now holds and must equal the record the station signed; a "
      "mismatch, a broken chain link or signature, a run id the plant holds from another "
      "station, or a station id another station archive holds (two stations claiming one id) is "
      "refused, named, and nothing after it ships.\n"
      "Exit 0 shipped (or nothing new), 1 the plant or the station could not be read or "
      "written (run it again: it resumes), 2 usage, 3 refused.\n"
      "Example:\n  imuqual sync --db station.db --to 'postgresql://ingest@plant-db/imuqual' "
      "--pubkey station.trust");
  return cmd;
}

int SyncCommand(const SyncOptions& o) {
  if (!store::IsPostgresUrl(o.to)) {
    LogError("--to " + o.to + ": the plant archive must be a postgresql:// URL");
    return kExitUsage;
  }
  if (store::IsPostgresUrl(o.db_path)) {
    LogError("--db " + o.db_path + ": give the station's archive file (the plant is --to)");
    return kExitUsage;
  }
  store::SyncOptions options;
  for (const std::string& path : o.pubkey_paths) {
    auto keys = ReadPublicKeyFile(path);
    if (!keys.ok()) {
      LogError(keys.status().message());
      return kExitUsage;
    }
    options.trusted.insert(options.trusted.end(), keys->begin(), keys->end());
  }
  options.require_signatures = !options.trusted.empty() && !o.allow_unsigned;
  options.batch_entries = o.batch;
  options.new_archive_of = o.new_archive_of;
  options.claimed_by = "imuqual sync " + InstanceName() + " " + o.db_path;
  if (!o.quiet) {
    options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  }
  auto station = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!station.ok()) {
    LogError(station.status().message());
    return station.status().code() == Status::Code::kNotFound ? kExitUsage : kExitFailed;
  }
  auto plant = store::Archive::Open(o.to, store::Archive::Mode::kWrite);
  if (!plant.ok()) {
    LogError(plant.status().message());
    return kExitFailed;
  }
  auto report = store::SyncToPlant(**station, **plant, options);
  if (!report.ok()) {
    LogError("sync " + o.db_path + " -> " + (*plant)->path() + ": " + report.status().message() +
             " (what was shipped before stays; run it again to resume)");
    return kExitFailed;
  }
  const store::SyncReport& r = *report;
  if (r.archive_id.empty()) {
    std::printf("%s: no finalised run yet: nothing to ship\n", o.db_path.c_str());
    return 0;
  }
  std::printf(
      "%s (archive %s...) -> %s: chain entries %lld of %lld at the plant (were %lld); %lld runs "
      "shipped (%lld replaced: judged again), %lld rows inserted, %lld raw chunks (%.1f MB)\n",
      o.db_path.c_str(), r.archive_id.substr(0, 16).c_str(), (*plant)->path().c_str(),
      static_cast<long long>(r.shipped_after), static_cast<long long>(r.station_entries),
      static_cast<long long>(r.shipped_before), static_cast<long long>(r.runs_shipped),
      static_cast<long long>(r.runs_replaced), static_cast<long long>(r.rows_inserted),
      static_cast<long long>(r.chunks_inserted), static_cast<double>(r.chunk_bytes) / 1e6);
  if (!r.station_moved.empty()) std::printf("%s\n", r.station_moved.c_str());
  if (!r.partition_note.empty()) std::printf("note: %s\n", r.partition_note.c_str());
  if (r.behind) {
    std::printf(
        "the station archive is behind the plant (%lld entries here, %lld at the plant: restored "
        "from an older backup?): nothing to ship, nothing lost\n",
        static_cast<long long>(r.station_entries), static_cast<long long>(r.shipped_after));
  }
  if (!r.refusal.empty()) {
    LogError("refused: " + r.refusal);
    return kExitRefused;
  }
  return 0;
}

}  // namespace imuqual::cli
