#include "skylit/base/files.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <random>
#include <stdexcept>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"

namespace fs = std::filesystem;

namespace skylit {
namespace {

using test::TempDir;

// The names in `dir`, sorted: what a write left behind.
std::vector<std::string> entries(const TempDir& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir.path())) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::span<const std::byte> bytes_of(const std::string& s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

TEST(WriteFileAtomic, WritesReplacesAndLeavesNoTemporaries) {
  TempDir dir;
  const fs::path file = dir.path() / "manifest.json";
  write_file_atomic(file, std::string("first"));
  EXPECT_EQ(read_file(file), "first");
  std::string binary(70000, '\0');
  for (std::size_t i = 0; i < binary.size(); ++i) binary[i] = static_cast<char>(i * 31 % 256);
  write_file_atomic(file, bytes_of(binary));
  EXPECT_EQ(read_file(file), binary);
  write_file_atomic(file, std::string());
  EXPECT_EQ(read_file(file), "");
  EXPECT_EQ(entries(dir), std::vector<std::string>{"manifest.json"});
}

TEST(WriteFileAtomic, ThrowingCallbackLeavesTheOldFileIntact) {
  TempDir dir;
  const fs::path file = dir.path() / "basis.exr";
  write_file_atomic(file, std::string("old contents"));
  fs::path seen;
  EXPECT_THROW(write_file_atomic_with(file,
                                      [&](const fs::path& tmp) {
                                        seen = tmp;
                                        std::ofstream(tmp) << "half-written";
                                        throw std::runtime_error("disk full");
                                      }),
               std::runtime_error);
  EXPECT_EQ(read_file(file), "old contents");
  EXPECT_EQ(entries(dir), std::vector<std::string>{"basis.exr"});
  // The temporary sits beside the target and keeps its extension (libraries choose formats by it).
  EXPECT_EQ(seen.parent_path(), dir.path());
  EXPECT_EQ(seen.extension(), ".exr");
  EXPECT_NE(seen, file);
}

TEST(WriteFileAtomic, CallbackResultIsPublished) {
  TempDir dir;
  const fs::path file = dir.path() / "image.png";
  write_file_atomic_with(file, [](const fs::path& tmp) { std::ofstream(tmp, std::ios::binary) << "PNG!"; });
  EXPECT_EQ(read_file(file), "PNG!");
  EXPECT_EQ(entries(dir), std::vector<std::string>{"image.png"});
}

TEST(WriteFileAtomic, MissingDirectoryIsAnInputErrorNamingThePath) {
  TempDir dir;
  const fs::path file = dir.path() / "no-such-dir" / "out.bin";
  try {
    write_file_atomic(file, std::string("x"));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
  EXPECT_TRUE(entries(dir).empty());
}

TEST(ReadFile, UnreadableIsAnInputError) {
  TempDir dir;
  EXPECT_THROW(read_file(dir.path() / "missing.txt"), InputError);
  EXPECT_THROW(read_file(dir.path()), InputError);  // a directory
  EXPECT_THROW(sha256_file(dir.path() / "missing.txt"), InputError);
}

TEST(Sha256, KnownVectors) {
  EXPECT_EQ(sha256_hex(bytes_of("abc")), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(bytes_of("")), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex(bytes_of("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq")),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256, FileIsStreamedAndMatchesTheBuffer) {
  TempDir dir;
  // A million 'a's: the FIPS 180-2 long vector, larger than one read chunk.
  const std::string million(1000000, 'a');
  write_file_atomic(dir.path() / "a.bin", million);
  EXPECT_EQ(sha256_file(dir.path() / "a.bin"), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  EXPECT_EQ(sha256_hex(bytes_of(million)), sha256_file(dir.path() / "a.bin"));
}

TEST(EnsureWritableDirectory, CreatesNestedDirectories) {
  TempDir dir;
  const fs::path nested = dir.path() / "bake" / "site" / "v1";
  ensure_writable_directory(nested);
  EXPECT_TRUE(fs::is_directory(nested));
  EXPECT_TRUE(fs::is_empty(nested));  // the probe file is gone
  ensure_writable_directory(nested);  // existing is fine
}

TEST(EnsureWritableDirectory, PathUnderARegularFileIsAnInputError) {
  // Root ignores permission bits, so block creation with a regular file in the way.
  TempDir dir;
  write_file_atomic(dir.path() / "plain", std::string("x"));
  for (const fs::path& target : {dir.path() / "plain" / "out", dir.path() / "plain"}) {
    try {
      ensure_writable_directory(target);
      FAIL() << "expected InputError for " << target;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("cannot write to output directory '" + target.string() + "'"), std::string::npos)
          << message;
      EXPECT_NE(message.find("Fix: choose a directory you can write to with -o"), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace skylit
