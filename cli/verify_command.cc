#include "cli/verify_command.h"

#include <cstdio>

#include "common/keys.h"
#include "common/log.h"
#include "store/archive.h"
#include "store/chain.h"
#include "store/chain_verify.h"
#include "store/checksums.h"
#include "store/plant_sync.h"

namespace imuqual::cli {
namespace {

constexpr int kExitBroken = 1;
constexpr int kExitUsage = 2;
constexpr int kExitUnsigned = 3;

// "N runs: A, B, C" (the first few ids, then how many more).
std::string RunList(const std::vector<std::string>& ids) {
  constexpr size_t kShown = 20;
  std::string text = std::to_string(ids.size()) + (ids.size() == 1 ? " run" : " runs");
  for (size_t i = 0; i < ids.size() && i < kShown; ++i) text += (i == 0 ? ": " : ", ") + ids[i];
  if (ids.size() > kShown) text += ", ... (" + std::to_string(ids.size() - kShown) + " more)";
  return text;
}

int PrintHead(store::Db& db, const std::string& path) {
  auto print = [](const std::string& line) { std::printf("%s\n", line.c_str()); };
  auto problems = store::CheckChainLinks(db, print);
  if (!problems.ok()) {
    LogError(problems.status().message());
    return kExitBroken;
  }
  if (*problems > 0) {
    LogError(path + ": the chain is broken (" + std::to_string(*problems) +
             " problems): no head to keep");
    return kExitBroken;
  }
  auto head = store::ReadChainHead(db);
  if (!head.ok()) {
    LogError(head.status().message());
    return kExitBroken;
  }
  std::printf("%s\n", head->ToText().c_str());
  std::fprintf(stderr,
               "%s: chain head, %lld entries; keep this line outside the archive and check "
               "later with: imuqual verify --db %s --expect-head %s\n",
               path.c_str(), static_cast<long long>(head->entries), path.c_str(),
               head->ToText().c_str());
  return 0;
}

// A plant archive: every station archive's chain as shipped and every run
// against its signed record (store/plant_sync.h).
int VerifyPlantArchive(store::Archive& plant, const VerifyOptions& o,
                       const store::ChainVerifyOptions& chain) {
  if (o.head || !o.expect_head.empty()) {
    LogError("--head and --expect-head are for a station's archive file; a plant archive keeps "
             "each station's head (verify checks them)");
    return kExitUsage;
  }
  store::SyncOptions options;
  options.trusted = chain.trusted;
  options.require_signatures = chain.require_signatures;
  auto report = store::VerifyPlant(
      plant, options, [](const std::string& line) { std::printf("%s\n", line.c_str()); });
  if (!report.ok()) {
    LogError(report.status().message());
    return kExitBroken;
  }
  std::fprintf(stderr,
               "%s: %lld station archives, %lld chain entries, %lld runs verified against their "
               "signed records%s; %lld problems\n",
               plant.path().c_str(), static_cast<long long>(report->archives),
               static_cast<long long>(report->entries),
               static_cast<long long>(report->runs_verified),
               chain.check_signatures ? " (signatures checked)" : " (signatures not checked: no --pubkey)",
               static_cast<long long>(report->problems));
  return report->problems > 0 ? kExitBroken : 0;
}

}  // namespace

CLI::App* AddVerifyCommand(CLI::App& app, VerifyOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "verify",
      "check an archive for damage (SQLite's integrity check, every checksum) and tampering "
      "(each run's signed record, the chain of finalised runs, signatures)");
  cmd->add_option("--db", o->db_path, "archive file")->required();
  CLI::Option* pubkey =
      cmd->add_option("--pubkey", o->pubkey_paths,
                      "trusted public key of the store (store.key.pub) or a trust file; "
                      "repeatable (several stations' stores, a rotated key). Without it "
                      "signatures are not checked");
  CLI::Option* expect =
      cmd->add_option("--expect-head", o->expect_head,
                      "N:HEX printed by an earlier --head and kept elsewhere: the chain must "
                      "still hold that entry (finds the newest runs deleted with their entries)");
  cmd->add_flag("--allow-unsigned", o->allow_unsigned,
                "with --pubkey: runs a store archived without --sign-key are listed as unsigned "
                "(exit 3) instead of breaking the chain (exit 1)")
      ->needs(pubkey);
  cmd->add_flag("--head", o->head,
                "print the chain's head (N:HEX: its entry count and last hash) to keep outside "
                "the archive, after checking the chain's links")
      ->excludes(pubkey)
      ->excludes(expect);
  cmd->footer(
      "Prints one line per problem (naming the run or chain entry and what broke) and a summary "
      "on stderr. Exit 0 clean, 1 damaged or tampered, 2 usage error, 3 (with --pubkey) "
      "nothing broken but not all verified: runs archived before schema 7 (or, with "
      "--allow-unsigned, by a store without --sign-key) or runs not finalised that carry a "
      "verdict: listed, never reported verified. With --pubkey an unsigned chain entry is "
      "broken (signatures stripped, or a store without --sign-key) unless --allow-unsigned.\n"
      "The chain protects against edits, swaps and deletions by anyone without the store's "
      "signing key; whoever holds that key can re-sign an edited archive, and deleting the "
      "newest runs with their entries is found only against a head kept elsewhere.\n"
      "Examples:\n  imuqual verify --db station.db --pubkey store.key.pub\n"
      "  imuqual verify --db station.db --head > head.txt\n"
      "  imuqual verify --db station.db --pubkey store.key.pub --expect-head \"$(cat head.txt)\"");
  return cmd;
}

int VerifyCommand(const VerifyOptions& o) {
  store::ChainVerifyOptions chain;
  if (!o.expect_head.empty()) {
    store::ChainHead head;
    if (!store::ChainHead::Parse(o.expect_head, &head)) {
      LogError("--expect-head '" + o.expect_head + "': expected N:HEX as --head prints it");
      return kExitUsage;
    }
    chain.expect_head = head;
  }
  for (const std::string& path : o.pubkey_paths) {
    auto keys = ReadPublicKeyFile(path);
    if (!keys.ok()) {
      LogError(keys.status().WithContext("--pubkey").message());
      return kExitUsage;
    }
    chain.trusted.insert(chain.trusted.end(), keys->begin(), keys->end());
  }
  chain.check_signatures = !o.pubkey_paths.empty();
  chain.require_signatures = chain.check_signatures && !o.allow_unsigned;

  auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return kExitBroken;
  }
  if ((*archive)->postgres()) return VerifyPlantArchive(**archive, o, chain);
  store::Db& db = (*archive)->db();
  if (o.head) return PrintHead(db, o.db_path);
  auto print = [](const std::string& line) { std::printf("%s\n", line.c_str()); };
  auto integrity = store::CheckIntegrity(db, print);
  if (!integrity.ok()) {
    LogError(integrity.status().message());
    return kExitBroken;
  }
  auto checksums = store::CheckChecksums(db, -1, print);
  if (!checksums.ok()) {
    // A file damaged enough stops the reading itself: that is a finding too.
    print("checksums: " + checksums.status().message());
    return kExitBroken;
  }
  auto schema = store::CheckSchema(db, print);
  if (!schema.ok()) {
    print("schema: " + schema.status().message());
    return kExitBroken;
  }
  auto report = store::VerifyChain(db, chain, print);
  if (!report.ok()) {
    print("chain: " + report.status().message());
    return kExitBroken;
  }
  const store::ChainVerifyReport& r = *report;
  std::fprintf(stderr, "chain: %lld entries, head %s\n", static_cast<long long>(r.head.entries),
               r.head.ToText().c_str());
  if (!r.verified.empty()) {
    std::fprintf(stderr, "signed and verified: %zu runs\n", r.verified.size());
  }
  if (!r.signed_unchecked.empty()) {
    std::fprintf(stderr,
                 "signatures not checked (no --pubkey): %zu runs carry a signature, "
                 "not verified\n",
                 r.signed_unchecked.size());
  } else if (!chain.check_signatures) {
    std::fprintf(stderr, "signatures not checked (no --pubkey)\n");
  }
  std::vector<std::string> unsigned_runs = r.unsigned_legacy;
  unsigned_runs.insert(unsigned_runs.end(), r.unsigned_keyless.begin(), r.unsigned_keyless.end());
  if (!unsigned_runs.empty()) {
    std::fprintf(stderr,
                 "unsigned (%zu archived before schema 7, %zu by a store without --sign-key; "
                 "not verified): %s\n",
                 r.unsigned_legacy.size(), r.unsigned_keyless.size(),
                 RunList(unsigned_runs).c_str());
  }
  if (!r.open.empty()) {
    std::fprintf(stderr, "open (not finalised, signed when they are): %s\n",
                 RunList(r.open).c_str());
  }
  if (!r.open_judged.empty()) {
    std::fprintf(stderr,
                 "open runs that carry a verdict (not finalised: not evidence yet; a store still "
                 "writing them, or rows written behind its back): %s\n",
                 RunList(r.open_judged).c_str());
  }
  const int64_t problems = *integrity + *checksums + *schema + r.problems;
  if (problems > 0) {
    LogError(o.db_path + ": " + std::to_string(problems) + " problems");
    return kExitBroken;
  }
  if (chain.check_signatures && !unsigned_runs.empty()) {
    LogError(o.db_path + ": nothing broken, but " + RunList(unsigned_runs) +
             " unsigned: not verified");
    return kExitUnsigned;
  }
  if (chain.check_signatures && !r.open_judged.empty()) {
    LogError(o.db_path + ": nothing broken, but " + RunList(r.open_judged) +
             " carry a verdict without being finalised: not verified");
    return kExitUnsigned;
  }
  std::fprintf(stderr, "%s: ok (integrity check, every checksum, every record and the chain%s)\n",
               o.db_path.c_str(),
               chain.check_signatures ? ", every signature" : "; signatures not checked");
  return 0;
}

}  // namespace imuqual::cli
