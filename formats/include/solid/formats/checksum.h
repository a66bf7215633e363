// Checksums and stable hashes. Every blob we store carries XXH64(bytes, seed 0).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace solid {

uint64_t Xxh64(std::span<const uint8_t> bytes, uint64_t seed = 0);
uint64_t Xxh64(std::string_view bytes, uint64_t seed = 0);

// 16 lower-case hex digits, zero-padded: the form used in manifests and reports.
std::string Hex64(uint64_t value);
// Inverse of Hex64; accepts an optional "0x" prefix. Returns false on anything else.
bool ParseHex64(std::string_view text, uint64_t* value);

// SQLite INTEGER is signed: unsigned 64-bit values are stored with the same bits.
inline int64_t ToSqlInt(uint64_t v) { return static_cast<int64_t>(v); }
inline uint64_t FromSqlInt(int64_t v) { return static_cast<uint64_t>(v); }

}  // namespace solid
