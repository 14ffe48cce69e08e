#include "common/keys.h"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace imuqual {
namespace {

constexpr char kStationTag[] = "imuqual-station-key";
constexpr char kSigningTag[] = "imuqual-signing-key";
constexpr char kPublicTag[] = "imuqual-public-key";
constexpr char kVersion[] = "v1";
constexpr size_t kMaxKeyFileBytes = 64 * 1024;

std::string Base64Of(const uint8_t* data, size_t size) {
  std::string out(sodium_base64_encoded_len(size, sodium_base64_VARIANT_ORIGINAL), '\0');
  sodium_bin2base64(out.data(), out.size(), data, size, sodium_base64_VARIANT_ORIGINAL);
  out.resize(std::strlen(out.c_str()));
  return out;
}

// Decodes base64 of exactly `size` bytes.
bool DecodeBase64(std::string_view b64, uint8_t* out, size_t size) {
  size_t len = 0;
  const char* end = nullptr;
  if (sodium_base642bin(out, size, b64.data(), b64.size(), nullptr, &len, &end,
                        sodium_base64_VARIANT_ORIGINAL) != 0) {
    return false;
  }
  return len == size && end == b64.data() + b64.size();
}

// The words of each line of `text` that is neither empty nor a comment.
std::vector<std::vector<std::string>> KeyLines(std::string_view text) {
  std::vector<std::vector<std::string>> lines;
  std::istringstream in{std::string(text)};
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string word; words >> word;) w.push_back(word);
    if (w.empty() || w[0][0] == '#') continue;
    lines.push_back(std::move(w));
  }
  return lines;
}

std::string ModeText(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

// Reads a key file; a secret one must not be readable by group or others.
Result<std::string> ReadKeyText(const std::string& path, bool secret) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::NotFound("key file " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return Status::InvalidArgument("key file " + path + " is not a regular file");
  }
  if (secret && (st.st_mode & 077) != 0) {
    ::close(fd);
    return Status::InvalidArgument("key file " + path + " is readable by others (mode " +
                                   ModeText(st.st_mode) + "): chmod 600 " + path);
  }
  if (st.st_size > static_cast<off_t>(kMaxKeyFileBytes)) {
    ::close(fd);
    return Status::InvalidArgument("key file " + path + " is too large to be a key file");
  }
  std::string text(static_cast<size_t>(st.st_size), '\0');
  size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  ::close(fd);
  text.resize(got);
  return text;
}

Status WriteNewFile(const std::string& path, const std::string& text, mode_t mode) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) {
    if (errno == EEXIST)
      return Status::InvalidArgument("key file " + path + " exists already (never overwritten)");
    return Status::IoError("cannot create key file " + path + ": " + std::strerror(errno));
  }
  (void)::fchmod(fd, mode);  // whatever the umask said, owner-only for secrets
  size_t put = 0;
  while (put < text.size()) {
    const ssize_t n = ::write(fd, text.data() + put, text.size() - put);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      ::unlink(path.c_str());
      return Status::IoError("cannot write key file " + path + ": " + why);
    }
    put += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    return Status::IoError("cannot write key file " + path + ": " + std::strerror(errno));
  }
  return Status::Ok();
}

std::string IdOf(const char* label, const uint8_t* data, size_t size) {
  uint8_t digest[8];
  crypto_generichash_state state;
  crypto_generichash_init(&state, nullptr, 0, sizeof digest);
  crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(label),
                            std::strlen(label) + 1);
  crypto_generichash_update(&state, data, size);
  crypto_generichash_final(&state, digest, sizeof digest);
  return HexOf(digest, sizeof digest);
}

}  // namespace

Status InitCrypto() {
  static const int rc = sodium_init();  // thread-safe static init; sodium_init is idempotent
  if (rc < 0) return Status::Unavailable("libsodium could not be initialized");
  return Status::Ok();
}

bool IsSigningRole(std::string_view role) {
  for (std::string_view r : kSigningRoles) {
    if (r == role) return true;
  }
  return false;
}

StationKey::~StationKey() { sodium_memzero(bytes.data(), bytes.size()); }
SigningKey::~SigningKey() { sodium_memzero(secret.data(), secret.size()); }

std::string StationKey::Id() const {
  return IdOf("imuqual station key id", bytes.data(), bytes.size());
}
std::string PublicKey::Id() const {
  return IdOf("imuqual public key id", bytes.data(), bytes.size());
}

std::string PublicKey::ToText() const {
  return std::string(kPublicTag) + " " + kVersion + " " + role + " " +
         Base64Of(bytes.data(), bytes.size());
}

PublicKey SigningKey::Public() const {
  PublicKey pub;
  pub.role = role;
  crypto_sign_ed25519_sk_to_pk(pub.bytes.data(), secret.data());
  return pub;
}

Result<StationKey> GenerateStationKey() {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  StationKey key;
  randombytes_buf(key.bytes.data(), key.bytes.size());
  return key;
}

Result<SigningKey> GenerateSigningKey(const std::string& role) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  if (!IsSigningRole(role)) {
    return Status::InvalidArgument("role '" + role + "' signs nothing (acquire, analyze or store)");
  }
  SigningKey key;
  key.role = role;
  std::array<uint8_t, kPublicKeyBytes> pk{};
  crypto_sign_keypair(pk.data(), key.secret.data());
  return key;
}

Status WriteStationKeyFile(const std::string& path, const StationKey& key) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  std::string text = "# imuqual station key " + key.Id() +
                     ": every process of the station bus holds it; keep it secret\n" + kStationTag +
                     " " + kVersion + " " + Base64Of(key.bytes.data(), key.bytes.size()) + "\n";
  Status st = WriteNewFile(path, text, 0600);
  sodium_memzero(text.data(), text.size());
  return st;
}

Status WriteSigningKeyFiles(const std::string& path, const SigningKey& key) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  const PublicKey pub = key.Public();
  const std::string pub_path = path + ".pub";
  struct stat st {};
  if (::stat(pub_path.c_str(), &st) == 0) {
    return Status::InvalidArgument("key file " + pub_path + " exists already (never overwritten)");
  }
  std::string text = "# imuqual signing key of role " + key.role + " (public key " + pub.Id() +
                     "): only the " + key.role + " process holds it; keep it secret\n" +
                     kSigningTag + " " + kVersion + " " + key.role + " " +
                     Base64Of(key.secret.data(), key.secret.size()) + "\n";
  Status s = WriteNewFile(path, text, 0600);
  sodium_memzero(text.data(), text.size());
  IMUQUAL_RETURN_IF_ERROR(s);
  return WriteNewFile(
      pub_path,
      "# imuqual public key of role " + key.role + " (" + pub.Id() + ")\n" + pub.ToText() + "\n",
      0644);
}

Result<StationKey> ReadStationKeyFile(const std::string& path) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  auto text = ReadKeyText(path, /*secret=*/true);
  if (!text.ok()) return text.status();
  const auto lines = KeyLines(*text);
  sodium_memzero(text->data(), text->size());
  if (lines.size() != 1 || lines[0].size() != 3 || lines[0][0] != kStationTag ||
      lines[0][1] != kVersion) {
    return Status::InvalidArgument("key file " + path + " is not a station key ('" + kStationTag +
                                   " " + kVersion + " BASE64'; make one with imuqual keygen)");
  }
  StationKey key;
  if (!DecodeBase64(lines[0][2], key.bytes.data(), key.bytes.size())) {
    return Status::InvalidArgument("key file " + path + ": the key is not base64 of 32 bytes");
  }
  return key;
}

Result<SigningKey> ReadSigningKeyFile(const std::string& path) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  auto text = ReadKeyText(path, /*secret=*/true);
  if (!text.ok()) return text.status();
  const auto lines = KeyLines(*text);
  sodium_memzero(text->data(), text->size());
  if (lines.size() != 1 || lines[0].size() != 4 || lines[0][0] != kSigningTag ||
      lines[0][1] != kVersion) {
    return Status::InvalidArgument("key file " + path + " is not a signing key ('" + kSigningTag +
                                   " " + kVersion +
                                   " ROLE BASE64'; make one with imuqual keygen --role)");
  }
  SigningKey key;
  key.role = lines[0][2];
  if (!IsSigningRole(key.role)) {
    return Status::InvalidArgument("key file " + path + ": unknown role '" + key.role + "'");
  }
  if (!DecodeBase64(lines[0][3], key.secret.data(), key.secret.size())) {
    return Status::InvalidArgument("key file " + path + ": the key is not base64 of 64 bytes");
  }
  // The secret key holds its public key: check they belong together.
  std::array<uint8_t, kPublicKeyBytes> seed{}, pk{};
  std::array<uint8_t, kSecretKeyBytes> sk{};
  crypto_sign_ed25519_sk_to_seed(seed.data(), key.secret.data());
  crypto_sign_seed_keypair(pk.data(), sk.data(), seed.data());
  const bool same = sodium_memcmp(sk.data(), key.secret.data(), sk.size()) == 0;
  sodium_memzero(seed.data(), seed.size());
  sodium_memzero(sk.data(), sk.size());
  if (!same) return Status::InvalidArgument("key file " + path + ": damaged signing key");
  return key;
}

Result<std::vector<PublicKey>> ParsePublicKeys(std::string_view text, const std::string& origin) {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  std::vector<PublicKey> keys;
  for (const auto& w : KeyLines(text)) {
    if (w.size() != 4 || w[0] != kPublicTag || w[1] != kVersion) {
      return Status::InvalidArgument(origin + ": not a public key line ('" + kPublicTag + " " +
                                     kVersion + " ROLE BASE64')");
    }
    PublicKey key;
    key.role = w[2];
    if (!IsSigningRole(key.role))
      return Status::InvalidArgument(origin + ": unknown role '" + key.role + "'");
    if (!DecodeBase64(w[3], key.bytes.data(), key.bytes.size())) {
      return Status::InvalidArgument(origin + ": the " + key.role +
                                     " key is not base64 of 32 bytes");
    }
    for (const PublicKey& k : keys) {
      if (k.role == key.role) {
        return Status::InvalidArgument(origin + ": two public keys for role " + key.role);
      }
    }
    keys.push_back(std::move(key));
  }
  if (keys.empty()) return Status::InvalidArgument(origin + ": no public key in it");
  return keys;
}

Result<std::vector<PublicKey>> ReadPublicKeyFile(const std::string& path) {
  auto text = ReadKeyText(path, /*secret=*/false);
  if (!text.ok()) return text.status();
  return ParsePublicKeys(*text, "key file " + path);
}

Signature Sign(const SigningKey& key, const void* message, size_t size) {
  Signature sig{};
  crypto_sign_detached(sig.data(), nullptr, static_cast<const unsigned char*>(message), size,
                       key.secret.data());
  return sig;
}

bool VerifySignature(const PublicKey& key, const Signature& signature, const void* message,
                     size_t size) {
  return crypto_sign_verify_detached(signature.data(), static_cast<const unsigned char*>(message),
                                     size, key.bytes.data()) == 0;
}

std::string HexOf(const void* data, size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  const auto* b = static_cast<const uint8_t*>(data);
  std::string out(size * 2, '0');
  for (size_t i = 0; i < size; ++i) {
    out[2 * i] = kDigits[b[i] >> 4];
    out[2 * i + 1] = kDigits[b[i] & 15];
  }
  return out;
}

bool ParseHex(std::string_view hex, void* out, size_t size) {
  if (hex.size() != 2 * size) return false;
  auto* b = static_cast<uint8_t*>(out);
  auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (size_t i = 0; i < size; ++i) {
    const int hi = nibble(hex[2 * i]), lo = nibble(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) return false;
    b[i] = static_cast<uint8_t>(hi << 4 | lo);
  }
  return true;
}

}  // namespace imuqual
