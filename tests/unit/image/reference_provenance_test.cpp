// Every stored reference under tests/data/reference has a provenance file beside it that says how
// and when it was made and holds its SHA-256, so a reference replaced without a record fails here.
#include <gtest/gtest.h>
#include <openssl/evp.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace rtpm {
namespace {

namespace fs = std::filesystem;

std::string sha256Hex(const std::string& bytes) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    EXPECT_EQ(EVP_Digest(bytes.data(), bytes.size(), digest, &len, EVP_sha256(), nullptr), 1);
    static const char* kHex = "0123456789abcdef";
    std::string hex;
    for (unsigned int i = 0; i < len; ++i) hex += {kHex[digest[i] >> 4], kHex[digest[i] & 15]};
    return hex;
}

std::string readAll(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(ReferenceData, EveryStoredReferenceHasAProvenanceWithItsHash) {
    const fs::path dir = fs::path(RTPM_TEST_DATA_DIR) / "reference";
    int references = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (!entry.is_regular_file() || entry.path().extension() == ".provenance") continue;
        ++references;
        const fs::path provenance = entry.path().string() + ".provenance";
        ASSERT_TRUE(fs::exists(provenance)) << entry.path() << " has no provenance file beside it";
        const std::string text = readAll(provenance);
        for (const char* field : {"\nfile: ", "\nsha256: ", "\nmade: ", "\ncommand: ", "\nused by: "})
            EXPECT_NE(text.find(field), std::string::npos) << provenance << " lacks" << field;
        EXPECT_NE(text.find("sha256: " + sha256Hex(readAll(entry.path()))), std::string::npos)
            << provenance << " does not hold the SHA-256 of " << entry.path().filename()
            << " (regenerate both with tests/accuracy/make_reference.sh)";
    }
    EXPECT_GT(references, 0);
}

}  // namespace
}  // namespace rtpm
