#include "web/tls.h"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace imuqual::web {
namespace {

// OpenSSL's reason for the oldest error queued (the queue is emptied).
std::string OpenSslReason() {
  const unsigned long code = ERR_get_error();
  ERR_clear_error();
  const char* reason = code == 0 ? nullptr : ERR_reason_error_string(code);
  return reason ? reason : "unknown OpenSSL error";
}

// A key file that asks for a pass phrase is refused rather than prompted for.
int NoPassphrase(char*, int, int, void*) { return -1; }

// Readable by this process: the error names the option and the file.
Status Readable(const char* option, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    return Status::InvalidArgument(std::string("serve: ") + option + " " + path + ": " +
                                   std::strerror(errno));
  }
  std::fclose(f);
  return Status::Ok();
}

}  // namespace

TlsContext::~TlsContext() { SSL_CTX_free(ctx_); }

Result<std::unique_ptr<TlsContext>> TlsContext::Load(const std::string& cert_path,
                                                     const std::string& key_path) {
  IMUQUAL_RETURN_IF_ERROR(Readable("--tls-cert", cert_path));
  IMUQUAL_RETURN_IF_ERROR(Readable("--tls-key", key_path));
  struct stat info {};
  if (::stat(key_path.c_str(), &info) == 0 && (info.st_mode & S_IROTH) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(info.st_mode & 07777));
    return Status::InvalidArgument("serve: --tls-key " + key_path +
                                   ": a private key readable by anyone (mode " + mode +
                                   "): chmod o-r it first");
  }
  ERR_clear_error();
  SSL_CTX* ctx = SSL_CTX_new(TLS_server_method());
  if (ctx == nullptr) return Status::Unavailable("serve: TLS: " + OpenSslReason());
  std::unique_ptr<TlsContext> tls(new TlsContext(ctx));
  SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION);
  SSL_CTX_set_options(
      ctx, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION | SSL_OP_CIPHER_SERVER_PREFERENCE);
  if (SSL_CTX_set_cipher_list(ctx, "ECDHE+AESGCM:ECDHE+CHACHA20:!aNULL") != 1)
    return Status::Unavailable("serve: TLS: " + OpenSslReason());
  // Writes on a non-blocking socket may end early and resume with the rest.
  SSL_CTX_set_mode(ctx, SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
  if (SSL_CTX_use_certificate_chain_file(ctx, cert_path.c_str()) != 1) {
    return Status::InvalidArgument("serve: --tls-cert " + cert_path + ": not a PEM certificate (" +
                                   OpenSslReason() + ")");
  }
  // The key read apart, so that a key of another certificate is told from
  // a file that is no key.
  std::FILE* key_file = std::fopen(key_path.c_str(), "rb");
  EVP_PKEY* key =
      key_file ? PEM_read_PrivateKey(key_file, nullptr, NoPassphrase, nullptr) : nullptr;
  if (key_file) std::fclose(key_file);
  if (key == nullptr) {
    return Status::InvalidArgument("serve: --tls-key " + key_path +
                                   ": not an unencrypted PEM private key (" + OpenSslReason() +
                                   ")");
  }
  const bool matches = X509_check_private_key(SSL_CTX_get0_certificate(ctx), key) == 1;
  const bool used = matches && SSL_CTX_use_PrivateKey(ctx, key) == 1;
  EVP_PKEY_free(key);
  if (!matches) {
    ERR_clear_error();
    return Status::InvalidArgument("serve: --tls-key " + key_path +
                                   ": not the key of the certificate in " + cert_path);
  }
  if (!used)
    return Status::InvalidArgument("serve: --tls-key " + key_path + ": " + OpenSslReason());
  return tls;
}

}  // namespace imuqual::web
