// Content digests: FNV-1a for fast fingerprints of simulator state and θ, SHA-256 for files and
// configurations whose identity is recorded (policy weights, attribution checks).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace dh {

inline constexpr std::uint64_t kFnv1a64Basis = 0xcbf29ce484222325ull;
inline constexpr std::uint32_t kFnv1a32Basis = 0x811c9dc5u;

/// FNV-1a over `n` bytes, continuing from `h`.
std::uint64_t fnv1a64(const void* data, std::size_t n, std::uint64_t h = kFnv1a64Basis);
std::uint32_t fnv1a32(const void* data, std::size_t n, std::uint32_t h = kFnv1a32Basis);

/// SHA-256 of `size` bytes as 64 lowercase hex digits; throws std::runtime_error if OpenSSL fails.
std::string sha256_hex(const void* data, std::size_t size);
inline std::string sha256_hex(std::string_view text) { return sha256_hex(text.data(), text.size()); }

}  // namespace dh
