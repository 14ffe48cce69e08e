#include "common/keys.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

namespace imuqual {
namespace {

class KeysTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/imuqual-keys-XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  std::string dir_;
};

mode_t ModeOf(const std::string& path) {
  struct stat st {};
  EXPECT_EQ(::stat(path.c_str(), &st), 0);
  return st.st_mode & 07777;
}

TEST_F(KeysTest, StationKeyRoundTripsOwnerOnlyAndNeverOverwrites) {
  auto key = GenerateStationKey();
  ASSERT_TRUE(key.ok());
  const std::string path = Path("station.key");
  ASSERT_TRUE(WriteStationKeyFile(path, *key).ok());
  EXPECT_EQ(ModeOf(path), 0600u);
  auto back = ReadStationKeyFile(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->bytes, key->bytes);
  EXPECT_EQ(back->Id(), key->Id());
  EXPECT_EQ(key->Id().size(), 16u);

  auto other = GenerateStationKey();
  Status again = WriteStationKeyFile(path, *other);
  EXPECT_FALSE(again.ok());
  EXPECT_NE(again.message().find("exists already"), std::string::npos) << again.message();
  EXPECT_EQ(ReadStationKeyFile(path)->bytes, key->bytes);  // untouched
  EXPECT_NE(other->bytes, key->bytes);
}

TEST_F(KeysTest, SecretKeyReadableByOthersIsRefusedNamingTheMode) {
  auto key = GenerateStationKey();
  const std::string path = Path("station.key");
  ASSERT_TRUE(WriteStationKeyFile(path, *key).ok());
  ASSERT_EQ(::chmod(path.c_str(), 0644), 0);
  auto back = ReadStationKeyFile(path);
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.status().message().find("readable by others (mode 0644)"), std::string::npos)
      << back.status().message();
}

TEST_F(KeysTest, SigningKeySignsAndOnlyItsPublicKeyVerifies) {
  auto key = GenerateSigningKey("analyze");
  ASSERT_TRUE(key.ok());
  const std::string path = Path("analyze.key");
  ASSERT_TRUE(WriteSigningKeyFiles(path, *key).ok());
  EXPECT_EQ(ModeOf(path), 0600u);
  EXPECT_EQ(ModeOf(path + ".pub"), 0644u);
  auto back = ReadSigningKeyFile(path);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->role, "analyze");
  auto pubs = ReadPublicKeyFile(path + ".pub");
  ASSERT_TRUE(pubs.ok()) << pubs.status().message();
  ASSERT_EQ(pubs->size(), 1u);
  EXPECT_EQ((*pubs)[0].role, "analyze");
  EXPECT_EQ((*pubs)[0].bytes, key->Public().bytes);

  const std::string message = "verdict PASS";
  const Signature sig = Sign(*back, message.data(), message.size());
  EXPECT_TRUE(VerifySignature((*pubs)[0], sig, message.data(), message.size()));
  const std::string altered = "verdict FAIL";
  EXPECT_FALSE(VerifySignature((*pubs)[0], sig, altered.data(), altered.size()));
  auto stranger = GenerateSigningKey("analyze");
  EXPECT_FALSE(VerifySignature(stranger->Public(), sig, message.data(), message.size()));
}

TEST_F(KeysTest, TrustFileHoldsOneKeyPerRole) {
  auto a = GenerateSigningKey("acquire"), s = GenerateSigningKey("store");
  const std::string text =
      "# the station's roles\n" + a->Public().ToText() + "\n\n" + s->Public().ToText() + "\n";
  auto keys = ParsePublicKeys(text, "trust");
  ASSERT_TRUE(keys.ok()) << keys.status().message();
  ASSERT_EQ(keys->size(), 2u);
  EXPECT_EQ((*keys)[1].role, "store");

  auto dup = ParsePublicKeys(a->Public().ToText() + "\n" + a->Public().ToText(), "trust");
  ASSERT_FALSE(dup.ok());
  EXPECT_NE(dup.status().message().find("two public keys for role acquire"), std::string::npos);
  EXPECT_FALSE(ParsePublicKeys("imuqual-public-key v1 operator AAAA", "trust").ok());
  EXPECT_FALSE(ParsePublicKeys("imuqual-public-key v1 store AAAA", "trust").ok());  // too short
  EXPECT_FALSE(ParsePublicKeys("# nothing\n", "trust").ok());
}

TEST_F(KeysTest, WrongKindsAndDamageAreRefusedWithTheFileNamed) {
  const std::string path = Path("junk.key");
  {
    std::ofstream out(path);
    out << "imuqual-station-key v1 not-base64!\n";
  }
  ::chmod(path.c_str(), 0600);
  auto st = ReadStationKeyFile(path);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.status().message().find(path), std::string::npos);
  EXPECT_FALSE(ReadSigningKeyFile(path).ok());

  // A signing key whose public half was altered does not pass for a key.
  auto key = GenerateSigningKey("store");
  key->secret[40] ^= 1;
  ASSERT_TRUE(WriteSigningKeyFiles(Path("bad.key"), *key).ok());
  auto bad = ReadSigningKeyFile(Path("bad.key"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("damaged"), std::string::npos);
  EXPECT_FALSE(ReadStationKeyFile(Path("missing.key")).ok());
  EXPECT_FALSE(GenerateSigningKey("operator").ok());
}

TEST(HexTest, RoundTrips) {
  const uint8_t bytes[] = {0x00, 0x9f, 0xa0, 0xff};
  EXPECT_EQ(HexOf(bytes, 4), "009fa0ff");
  uint8_t back[4];
  ASSERT_TRUE(ParseHex("009FA0ff", back, 4));
  EXPECT_EQ(std::memcmp(back, bytes, 4), 0);
  EXPECT_FALSE(ParseHex("009fa0f", back, 4));
  EXPECT_FALSE(ParseHex("009fa0fg", back, 4));
}

}  // namespace
}  // namespace imuqual
