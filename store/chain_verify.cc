#include "store/chain_verify.h"

#include "store/schema.h"

#include <algorithm>
#include <map>
#include <set>

namespace imuqual::store {
namespace {

// Seq ranges for a message, the first few of them.
std::string ShownRanges(const std::vector<int64_t>& seqs) {
  std::string text = SeqRangesText(seqs);
  constexpr size_t kShown = 80;
  if (text.size() > kShown) text = text.substr(0, text.find(',', kShown - 10)) + ",...";
  return text;
}

std::string Plural(size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

bool StartsWith(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

enum class SignatureState { kUnsigned, kTrusted, kUnchecked, kBad };

// What the walk learned of a run's last entry.
struct LastEntry {
  int64_t entry = 0;
  std::string kind;
  bool sound = true;  // its hash, link and signature hold
  SignatureState signature = SignatureState::kUnsigned;
};

struct Walk {
  int64_t problems = 0;
  ChainHead head;
  std::map<std::string, LastEntry> last;  // by run id
  std::set<std::string> legacy;           // runs listed by a migration entry
  int64_t migration_entry = 0;
};

const PublicKey* FindKey(const std::vector<PublicKey>& keys, const std::string& id) {
  for (const PublicKey& k : keys) {
    if (k.Id() == id) return &k;
  }
  return nullptr;
}

Status WalkChain(Db& db, const ChainVerifyOptions& o, bool links_only,
                 const std::function<void(const std::string&)>& problem, Walk* w) {
  auto report = [&](const std::string& line) {
    ++w->problems;
    problem(line);
  };
  int64_t expected = 1, last_signed = 0;
  Digest prev{};
  std::optional<Digest> kept_entry_hash;
  IMUQUAL_RETURN_IF_ERROR(ForEachChainEntry(db, [&](const ChainEntry& e) {
    const bool migration = e.kind == kEntryMigrated;
    const std::string entry = "entry " + std::to_string(e.entry);
    const std::string label = migration ? "chain: " + entry + " (the migration to schema 7)"
                                        : "chain: " + entry + " (run " + e.run_id + ")";
    bool sound = true;
    if (e.entry != expected) {
      report("chain: " + entry + " follows a missing entry (" +
             (e.entry - 1 > expected
                  ? "entries " + std::to_string(expected) + "-" + std::to_string(e.entry - 1) +
                        " deleted: runs were"
                  : "entry " + std::to_string(expected) + " deleted: a run was") +
             " deleted)");
      sound = false;
    } else if (e.prev_hash != prev) {
      report("chain: " + entry + " does not follow entry " + std::to_string(e.entry - 1) +
             " (entry " + std::to_string(e.entry - 1) + " was changed or replaced)");
      sound = false;
    }
    if (e.ComputeHash() != e.entry_hash) {
      report(label + " was changed since it was written (its hash does not match its contents)");
      sound = false;
    }
    expected = e.entry + 1;
    prev = e.entry_hash;
    w->head.entries = e.entry;
    w->head.hash = e.entry_hash;
    if (o.expect_head && o.expect_head->entries == e.entry) kept_entry_hash = e.entry_hash;
    if (links_only) return Status::Ok();

    SignatureState sig = SignatureState::kUnsigned;
    const bool has_id = !e.key_id.empty(), has_signature = !e.signature.empty();
    const std::string who = migration ? label : "run " + e.run_id;
    if (!has_id && !has_signature) {
      if (o.require_signatures && !migration) {
        report(label + " (run " + e.run_id +
               ") is unsigned, and signatures are required (signatures stripped, or a store "
               "without --sign-key: verify --allow-unsigned accepts such runs as unsigned)");
        sound = false;
      } else if (last_signed > 0) {
        report(label + " is unsigned although entry " + std::to_string(last_signed) +
               " before it is signed (signatures stripped, or a writer without the store key)");
        sound = false;
      }
    } else if (!has_signature) {
      report(label + ": its signature was removed");
      sig = SignatureState::kBad;
    } else if (!has_id) {
      report(label + ": a signature without a key id");
      sig = SignatureState::kBad;
    } else {
      last_signed = e.entry;
      sig = SignatureState::kUnchecked;
      if (o.check_signatures) {
        const PublicKey* key = FindKey(o.trusted, e.key_id);
        if (key == nullptr) {
          report(who + ": signed by an unknown key (key id " + e.key_id + ", chain " + entry + ")");
          sig = SignatureState::kBad;
        } else if (key->role != "store") {
          report(who + ": signed by the " + key->role + " key " + e.key_id +
                 ", not a store key (chain " + entry + ")");
          sig = SignatureState::kBad;
        } else if (!EntrySignatureVerifies(e, *key)) {
          report(who + ": the signature of chain " + entry +
                 " does not verify (the entry was changed since it was signed)");
          sig = SignatureState::kBad;
        } else {
          sig = SignatureState::kTrusted;
        }
      }
    }
    auto record = SignedRecord::Decode(e.record);
    if (!record.ok()) {
      report(label + ": its record is malformed");
      sound = false;
    } else if (migration) {
      w->migration_entry = e.entry;
      auto it = record->items.find("legacy_runs");
      const std::string listed = it == record->items.end() ? "" : it->second.bytes;
      for (size_t start = 0; start < listed.size();) {
        const size_t end = listed.find('\n', start);
        if (end == std::string::npos) break;
        w->legacy.insert(listed.substr(start, end - start));
        start = end + 1;
      }
    }
    if (!migration) {
      w->last[e.run_id] = {e.entry, e.kind, sound && sig != SignatureState::kBad, sig};
    }
    return Status::Ok();
  }));
  if (o.expect_head && o.expect_head->entries > 0) {
    const ChainHead& kept = *o.expect_head;
    const std::string n = std::to_string(kept.entries);
    if (!kept_entry_hash) {
      if (kept.entries > w->head.entries) {
        report("chain: the kept head (entry " + n + ") is missing: the chain ends at entry " +
               std::to_string(w->head.entries) +
               " (its newest entries were deleted, or the head is another archive's)");
      } else {
        report("chain: entry " + n + " of the kept head is missing (deleted)");
      }
    } else if (*kept_entry_hash != kept.hash) {
      report("chain: entry " + n +
             " does not match the kept head (the chain was rewritten since the head was kept)");
    }
  }
  return Status::Ok();
}

// Items of a record that stay settled while a judgement round is open.
bool Settled(const std::string& name) {
  if (StartsWith(name, "superseded_judgements")) return true;
  if (!StartsWith(name, "runs.")) return false;
  const std::vector<std::string>& open = OpenRunColumns();
  return std::find(open.begin(), open.end(), name.substr(5)) == open.end();
}

int64_t Count(const SignedRecord& r, const std::string& name) {
  auto it = r.items.find(name);
  return it == r.items.end() ? 0 : it->second.integer;
}

// The differences between a run's signed record and its record now, one
// line each. `open_round`: the run's last entry reopened it; only what is
// settled is compared, and chunks may have been added since.
void CompareRecords(const std::string& run_id, const SignedRecord& was, const SignedRecord& now,
                    const ChunkFindings& chunks, bool open_round,
                    const std::function<void(const std::string&)>& report) {
  const std::string run = "run " + run_id + ": ";
  std::set<std::string> names;
  for (const auto& [name, value] : was.items) names.insert(name);
  for (const auto& [name, value] : now.items) names.insert(name);
  std::vector<std::string> plan;
  std::set<std::string> tables;
  bool chunks_differ = false;
  for (const std::string& name : names) {
    auto a = was.items.find(name);
    auto b = now.items.find(name);
    const bool in_was = a != was.items.end(), in_now = b != now.items.end();
    if (in_was && in_now && a->second == b->second) continue;
    if (StartsWith(name, "raw_chunks.")) {
      chunks_differ = true;
      continue;
    }
    if (open_round && !Settled(name)) continue;
    if (name == "runs.plan" || name == "runs.plan_sha256") {
      plan.push_back(name.substr(5));
    } else if (StartsWith(name, "runs.")) {
      const bool digest = (in_was && a->second.type == CanonicalValue::Type::kDigest) ||
                          (in_now && b->second.type == CanonicalValue::Type::kDigest);
      report(run + name.substr(5) + " changed since signed" +
             (digest ? std::string()
                     : " (signed " + (in_was ? a->second.Display() : std::string("NULL")) +
                           ", now " + (in_now ? b->second.Display() : std::string("NULL")) + ")"));
    } else {
      std::string table = name;  // "measurements" and "measurements.rows": one line
      if (table.size() > 5 && table.compare(table.size() - 5, 5, ".rows") == 0) {
        table.resize(table.size() - 5);
      }
      if (!tables.insert(table).second) continue;
      report(run + table + " changed since signed (" +
             Plural(static_cast<size_t>(Count(was, table + ".rows")), "row", "rows") + " signed, " +
             std::to_string(Count(now, table + ".rows")) + " now)");
    }
  }
  if (!plan.empty()) {
    report(run + "plan does not match its signed digest (" +
           (plan.size() == 2 ? std::string("plan bytes and plan_sha256") : plan[0]) +
           " changed since signed)");
  }
  if (!chunks_differ) return;
  // Which chunks: the signed seqs against those archived now.
  std::vector<std::pair<int64_t, int64_t>> ranges;
  auto signed_seqs = was.items.find("raw_chunks.seqs");
  if (signed_seqs == was.items.end() || !ParseSeqRanges(signed_seqs->second.bytes, &ranges)) {
    report(run + "its signed chunk list is malformed");
    return;
  }
  auto present = [&](int64_t seq) {
    return std::binary_search(chunks.seqs.begin(), chunks.seqs.end(), seq);
  };
  auto is_signed = [&](int64_t seq) {
    return std::any_of(ranges.begin(), ranges.end(),
                       [seq](const auto& r) { return seq >= r.first && seq <= r.second; });
  };
  std::vector<int64_t> deleted, added;
  for (const auto& [first, last] : ranges) {
    for (int64_t seq = first; seq <= last; ++seq) {
      if (!present(seq)) deleted.push_back(seq);
    }
  }
  ChunkListDigest signed_part;
  for (size_t i = 0; i < chunks.seqs.size(); ++i) {
    if (is_signed(chunks.seqs[i])) {
      signed_part.Add(chunks.seqs[i], chunks.digests[i]);
    } else {
      added.push_back(chunks.seqs[i]);
    }
  }
  if (!deleted.empty()) {
    report(run + Plural(deleted.size(), "raw chunk", "raw chunks") + " deleted since signed (seq " +
           ShownRanges(deleted) + ")");
  }
  if (!added.empty() && !open_round) {
    report(run + Plural(added.size(), "raw chunk", "raw chunks") + " added since signed (seq " +
           ShownRanges(added) + ")");
  }
  auto signed_digest = was.items.find("raw_chunks.digest");
  const bool signed_part_differs =
      signed_digest == was.items.end() ||
      signed_digest->second != CanonicalValue::DigestOf(signed_part.Final());
  // Altered and damaged chunks are named chunk by chunk elsewhere.
  if (deleted.empty() && (added.empty() || open_round) && chunks.altered.empty() &&
      chunks.damaged.empty() && (signed_part_differs || !open_round)) {
    report(run +
           "raw chunks changed since signed (the list of chunk digests does not match its signed "
           "digest: chunks were changed and their digests recomputed)");
  }
}

}  // namespace

namespace {

// The views and triggers of a schema, by "type name", their SQL with runs
// of whitespace made one space.
Result<std::map<std::string, std::string>> SchemaObjects(Db& db) {
  auto s = db.Prepare(
      "SELECT type, name, COALESCE(sql, '') FROM sqlite_schema WHERE type IN ('view', 'trigger')");
  if (!s.ok()) return s.status();
  std::map<std::string, std::string> out;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    std::string sql, text = s->Text(2);
    for (char c : text) {
      const bool space = c == ' ' || c == '\n' || c == '\t' || c == '\r';
      if (space && (sql.empty() || sql.back() == ' ')) continue;
      sql += space ? ' ' : c;
    }
    while (!sql.empty() && sql.back() == ' ') sql.pop_back();
    out[s->Text(0) + " " + s->Text(1)] = std::move(sql);
  }
  return out;
}

}  // namespace

Result<int64_t> CheckSchema(Db& db, const std::function<void(const std::string&)>& problem) {
  auto fresh = Db::Open(":memory:", Db::Mode::kReadWrite);
  if (!fresh.ok()) return fresh.status();
  IMUQUAL_RETURN_IF_ERROR(Migrate(**fresh));
  auto want = SchemaObjects(**fresh);
  if (!want.ok()) return want.status();
  auto have = SchemaObjects(db);
  if (!have.ok()) return have.status();
  int64_t problems = 0;
  for (const auto& [name, sql] : *have) {
    auto it = want->find(name);
    if (it == want->end()) {
      problem("schema: " + name + " is not this version's (added to the file)");
      ++problems;
    } else if (it->second != sql) {
      problem("schema: " + name + " differs from this version's definition (edited)");
      ++problems;
    }
  }
  for (const auto& [name, sql] : *want) {
    if (have->count(name) == 0) {
      problem("schema: " + name + " is missing (dropped from the file)");
      ++problems;
    }
  }
  return problems;
}

Result<int64_t> CheckChainLinks(Db& db, const std::function<void(const std::string&)>& problem) {
  Walk w;
  IMUQUAL_RETURN_IF_ERROR(WalkChain(db, ChainVerifyOptions(), /*links_only=*/true, problem, &w));
  return w.problems;
}

Result<ChainVerifyReport> VerifyChain(Db& db, const ChainVerifyOptions& o,
                                      const std::function<void(const std::string&)>& problem) {
  Walk w;
  IMUQUAL_RETURN_IF_ERROR(WalkChain(db, o, /*links_only=*/false, problem, &w));
  ChainVerifyReport out;
  out.head = w.head;
  int64_t problems = w.problems;
  auto report = [&](const std::string& line) {
    ++problems;
    problem(line);
  };
  auto runs = db.Prepare(
      "SELECT run_key, run_id, finalized_utime IS NOT NULL, plan, COALESCE(plan_sha256, ''), "
      "verdict IS NOT NULL FROM runs ORDER BY run_id");
  if (!runs.ok()) return runs.status();
  for (;;) {
    auto row = runs->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    const int64_t key = runs->Int(0);
    const std::string run_id = runs->Text(1);
    const bool finalized = runs->Int(2) != 0;
    const std::vector<uint8_t> plan = runs->Blob(3);
    const std::string plan_sha256 = runs->Text(4);
    const int64_t before = problems;
    const bool legacy = w.legacy.erase(run_id) > 0;  // listed by the migration, still there
    if (!plan_sha256.empty()) {  // empty: no digest claimed (imuqual-history-gen's runs)
      uint8_t sha[crypto_hash_sha256_BYTES];
      crypto_hash_sha256(sha, plan.data(), plan.size());
      if (HexOf(sha, sizeof sha) != plan_sha256) {
        report("run " + run_id + ": its plan bytes do not hash to its plan_sha256");
      }
    }
    auto last = w.last.find(run_id);
    const bool chained = last != w.last.end();
    if (!chained && finalized && legacy) {
      out.unsigned_legacy.push_back(run_id);  // nothing signed to compare with
      continue;
    }
    ChunkFindings chunks;
    auto now = ComputeRunRecord(db, key, ChunkDigests::kRecomputed, &chunks);
    if (!now.ok()) return now.status();
    if (!chunks.altered.empty()) {
      report("run " + run_id + ": " + Plural(chunks.altered.size(), "raw chunk", "raw chunks") +
             " changed since written (seq " + ShownRanges(chunks.altered) +
             "): their bytes do not match their digests");
    }
    if (!chained) {
      if (!finalized) {
        out.open.push_back(run_id);
        if (runs->Int(5) != 0) out.open_judged.push_back(run_id);
      } else {
        report("run " + run_id +
               ": finalised but not in the chain (its chain entry was deleted, or the run was "
               "written behind the store's back)");
      }
      continue;
    }
    const LastEntry entry = last->second;
    w.last.erase(last);
    auto stored = ReadChainEntry(db, entry.entry);
    if (!stored.ok()) return stored.status();
    auto was = stored->has_value() ? SignedRecord::Decode((*stored)->record)
                                   : Result<SignedRecord>(Status::NotFound("entry gone"));
    if (!was.ok()) continue;  // reported by the walk
    const bool open_round = entry.kind == kEntryReopened;
    if (open_round && finalized) {
      report("run " + run_id + ": finalised after chain entry " + std::to_string(entry.entry) +
             " reopened it, without an entry of its own");
    }
    CompareRecords(run_id, *was, *now, chunks, open_round, report);
    if (open_round) {
      if (!finalized) out.open.push_back(run_id);
      continue;
    }
    if (problems != before || !entry.sound) continue;
    switch (entry.signature) {
      case SignatureState::kTrusted:
        out.verified.push_back(run_id);
        break;
      case SignatureState::kUnchecked:
        out.signed_unchecked.push_back(run_id);
        break;
      case SignatureState::kUnsigned:
        out.unsigned_keyless.push_back(run_id);
        break;
      case SignatureState::kBad:
        break;
    }
  }
  for (const auto& [run_id, entry] : w.last) {
    report("run " + run_id + ": deleted from the archive (chain entry " +
           std::to_string(entry.entry) + " records it)");
  }
  for (const std::string& run_id : w.legacy) {
    report("run " + run_id +
           ": deleted from the archive (listed by the migration to schema 7, "
           "chain entry " +
           std::to_string(w.migration_entry) + ")");
  }
  out.problems = problems;
  return out;
}

}  // namespace imuqual::store
