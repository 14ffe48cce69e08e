// Verification of the archive's signed records and hash chain (what
// `imuqual verify` checks beyond damage at rest; store/SCHEMA.md, "Signed
// records and the chain"):
//  - the chain: entries numbered 1..N without a gap, each linking to the
//    hash of the one before, each entry's stored hash matching its contents,
//    no unsigned entry after a signed one, and (when given) a head kept
//    elsewhere still in the chain;
//  - signatures (when trusted keys are given): each signed entry verifies
//    with the trusted key of role "store" its key id names;
//  - every run: its record recomputed from what the archive holds now (each
//    chunk's digest from its bytes) equals the record of its last chain
//    entry, item by item; a run signed in the chain (or listed by the
//    migration to schema 7) but gone from runs, and a finalised run the
//    chain does not know, are named; the plan's bytes hash to plan_sha256.
// Problems go one line each to `problem`, naming the run or the entry and
// what broke. Reads only (any read connection).
#ifndef IMUQUAL_STORE_CHAIN_VERIFY_H_
#define IMUQUAL_STORE_CHAIN_VERIFY_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/keys.h"
#include "common/status.h"
#include "store/chain.h"
#include "store/sqlite.h"

namespace imuqual::store {

struct ChainVerifyOptions {
  // Checks signatures against these keys (only role "store" keys sign
  // records). false: signatures are not checked, only present or not.
  bool check_signatures = false;
  std::vector<PublicKey> trusted;
  // A head kept elsewhere (imuqual verify --head): the chain must still hold
  // that entry with that hash.
  std::optional<ChainHead> expect_head;
  // Every entry but the migration's must be signed: an unsigned one is a
  // problem (signatures stripped, or a store without a signing key).
  bool require_signatures = false;
};

struct ChainVerifyReport {
  int64_t problems = 0;
  ChainHead head;  // as stored
  // Finalised runs whose record matches what the archive holds, by their
  // signature's state: verified with a trusted store key; signed but not
  // checked (no keys given); unsigned, archived before schema 7 (listed at
  // the migration) or by a writer without a signing key.
  std::vector<std::string> verified, signed_unchecked, unsigned_legacy, unsigned_keyless;
  // Runs not finalised (their chain entry comes when they are); of them,
  // those that carry a verdict (a store writing them now, or rows written
  // behind the store's back: not evidence until finalised).
  std::vector<std::string> open, open_judged;
};

Result<ChainVerifyReport> VerifyChain(Db& db, const ChainVerifyOptions& options,
                                      const std::function<void(const std::string&)>& problem);

// Views and triggers against this version's own (those of a fresh archive,
// whitespace aside): one problem per object added, removed or changed.
// Returns the number of problems.
Result<int64_t> CheckSchema(Db& db, const std::function<void(const std::string&)>& problem);

// The chain's links alone (numbering, prev_hash, each entry's hash), cheap:
// what `verify --head` checks before printing a head. Returns the number of
// problems.
Result<int64_t> CheckChainLinks(Db& db, const std::function<void(const std::string&)>& problem);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CHAIN_VERIFY_H_
