// The bytes of openpi's policy protocol: msgpack with openpi's numpy encoding
// (openpi_client.msgpack_numpy). An ndarray travels as the map
//   {"__ndarray__": true, "data": <bin: the raw little-endian elements>, "dtype": "<f4" | "|u1" | …,
//    "shape": [d0, d1, …]}
// and a numpy scalar as {"__npgeneric__": true, "data": <value>, "dtype": "<f8" | …}. openpi packs the
// dict keys it writes itself as Python bytes (msgpack bin) and the caller's keys ("observation/image",
// "actions") as Python str (msgpack str); a server only recognises an ndarray whose marker keys are bin, so
// the encoder writes them as bin. The decoders accept str or bin for every key.
// No transport here: these functions are pure and unit-tested on their own.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

#include "dh/policy/openpi_types.hpp"

namespace dh::policy {

/// A message that is not what the protocol says; the text says what is wrong with it (the client adds
/// which server sent it).
struct PolicyCodecError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// msgpack of openpi's LIBERO observation dict: "observation/image" and "observation/wrist_image" as
/// uint8 ndarrays (height, width, 3) at the size given (resize first: see resize_with_pad),
/// "observation/state" as a float32 ndarray (8,), "prompt" as str. std::invalid_argument when an image is
/// empty or its byte count is not width × height × 3.
std::string encode_observation(const PolicyQuery& query);

/// The action dict of a reply: "actions" must be an ndarray of shape (H, 7), H ≥ 1, dtype float32 or
/// float64 (little-endian), every value finite; "server_timing"/"infer_ms" is read when present (a number
/// or a numpy scalar); other keys are ignored. PolicyCodecError otherwise (not msgpack, trailing bytes,
/// not a map, no "actions", wrong shape, dtype or byte count), saying what was found.
ActionChunk decode_action_chunk(std::string_view message);

/// The metadata dict a server sends first, as JSON: maps (keys as text), arrays, numbers, booleans, nil
/// → null, str → string, bin → JSON binary; an ndarray stays the map it is on the wire. PolicyCodecError
/// when it is not one msgpack map.
nlohmann::json decode_metadata(std::string_view message);

}  // namespace dh::policy
