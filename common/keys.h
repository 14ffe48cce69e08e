// Keys of a station, on libsodium (never hand-rolled crypto).
//
// - The station key: 32 random bytes shared by every process of one station
//   bus. Every message on the bus carries a MAC under it (keyed BLAKE2b,
//   common/bus_seal.h), so only holders of the key can speak on the bus.
// - Signing keys: one Ed25519 key pair per role ("acquire", "analyze",
//   "store"). A process holds only its own role's secret key; everyone holds
//   the public keys (a trust file: the roles' `.pub` files concatenated).
//   Signatures on the verdict-bearing messages keep a compromised host from
//   speaking for another role, and the store signs the archive's records
//   with its key, so that an edit of the archive file is found.
//
// Files are one line of text each (lines starting with '#' are comments):
//   imuqual-station-key v1 <base64 of 32 bytes>
//   imuqual-signing-key v1 <role> <base64 of the 64-byte Ed25519 secret key>
//   imuqual-public-key v1 <role> <base64 of the 32-byte Ed25519 public key>
// A secret key file must be readable by its owner only (mode 0600 or
// stricter): one readable by the group or others is refused with a message
// naming the file and its mode. Key files are created exclusively (never
// overwritten).
//
// Thread-safety: the functions are thread-safe; the structs are values.
#ifndef IMUQUAL_COMMON_KEYS_H_
#define IMUQUAL_COMMON_KEYS_H_

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace imuqual {

// Initializes libsodium once (thread-safe, idempotent). Every function below
// calls it; call it yourself before using libsodium directly.
Status InitCrypto();

inline constexpr size_t kStationKeyBytes = 32;
inline constexpr size_t kSecretKeyBytes = 64;  // Ed25519 secret key (seed + public key)
inline constexpr size_t kPublicKeyBytes = 32;  // Ed25519 public key
inline constexpr size_t kSignatureBytes = 64;  // Ed25519 detached signature

// The roles that may hold a signing key, in the order of their role codes.
inline constexpr std::array<std::string_view, 3> kSigningRoles = {"acquire", "analyze", "store"};
bool IsSigningRole(std::string_view role);

struct StationKey {
  std::array<uint8_t, kStationKeyBytes> bytes{};
  ~StationKey();
  StationKey() = default;
  StationKey(const StationKey&) = default;
  StationKey& operator=(const StationKey&) = default;
  // 16 hex digits naming the key (BLAKE2b of the key under a fixed label):
  // safe to log and to archive, reveals nothing of the key.
  std::string Id() const;
};

struct PublicKey {
  std::string role;
  std::array<uint8_t, kPublicKeyBytes> bytes{};
  // 16 hex digits naming the key (BLAKE2b of the public key).
  std::string Id() const;
  // The public key file's line: "imuqual-public-key v1 ROLE BASE64".
  std::string ToText() const;
};

struct SigningKey {
  std::string role;
  std::array<uint8_t, kSecretKeyBytes> secret{};
  ~SigningKey();
  SigningKey() = default;
  SigningKey(const SigningKey&) = default;
  SigningKey& operator=(const SigningKey&) = default;
  PublicKey Public() const;
};

using Signature = std::array<uint8_t, kSignatureBytes>;

Result<StationKey> GenerateStationKey();
Result<SigningKey> GenerateSigningKey(const std::string& role);

// Writes a new key file (fails if `path` exists), mode 0600.
Status WriteStationKeyFile(const std::string& path, const StationKey& key);
// Writes the secret key to `path` (0600) and the public key to `path.pub`
// (0644); fails if either exists.
Status WriteSigningKeyFiles(const std::string& path, const SigningKey& key);

Result<StationKey> ReadStationKeyFile(const std::string& path);
Result<SigningKey> ReadSigningKeyFile(const std::string& path);
// A public key file, or a trust file: one or more public key lines (at most
// one per role). Also takes a single line of text (ParsePublicKeys).
Result<std::vector<PublicKey>> ReadPublicKeyFile(const std::string& path);
// Parses public key lines; `origin` names the text in errors.
Result<std::vector<PublicKey>> ParsePublicKeys(std::string_view text, const std::string& origin);

// Detached Ed25519 signature of `message` (empty secret: programmer error).
Signature Sign(const SigningKey& key, const void* message, size_t size);
bool VerifySignature(const PublicKey& key, const Signature& signature, const void* message,
                     size_t size);

// Lowercase hex of bytes.
std::string HexOf(const void* data, size_t size);
// Parses lowercase or uppercase hex of exactly `size` bytes.
bool ParseHex(std::string_view hex, void* out, size_t size);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_KEYS_H_
