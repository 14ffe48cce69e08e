// The TLS settings of `imuqual serve --tls-cert FILE --tls-key FILE`, on
// Debian's OpenSSL (never hand-rolled crypto):
//   - TLS 1.2 and 1.3 only (SSL 3, TLS 1.0 and 1.1 are refused);
//   - TLS 1.3: OpenSSL's default suites (AES-GCM, ChaCha20-Poly1305);
//     TLS 1.2: ECDHE key exchange with AEAD ciphers only (forward secrecy;
//     no CBC, no RSA key exchange), the server's order preferred;
//   - no renegotiation, no compression; session tickets kept (a browser opens
//     a connection per request here, and resumes its session on it).
// The certificate file is PEM, the server's certificate first, then any
// intermediate ones; the key file is its PEM private key (unencrypted), not
// readable by others than its owner and group.
#ifndef IMUQUAL_WEB_TLS_H_
#define IMUQUAL_WEB_TLS_H_

#include <openssl/ssl.h>

#include <memory>
#include <string>

#include "common/status.h"

namespace imuqual::web {

class TlsContext {
 public:
  // Loads the certificate chain and its key. Every error is one line naming
  // the file at fault: missing or unreadable, not PEM, a key readable by
  // others, or a key that does not belong to the certificate.
  static Result<std::unique_ptr<TlsContext>> Load(const std::string& cert_path,
                                                  const std::string& key_path);
  ~TlsContext();
  TlsContext(const TlsContext&) = delete;
  TlsContext& operator=(const TlsContext&) = delete;
  // Owned by this object; shared by every connection (OpenSSL makes an
  // SSL_CTX safe to use from several threads once set up).
  SSL_CTX* get() const { return ctx_; }

 private:
  explicit TlsContext(SSL_CTX* ctx) : ctx_(ctx) {}
  SSL_CTX* ctx_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_TLS_H_
