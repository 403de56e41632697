// A segmentation backend that asks an external SAM-style server over HTTP (libcurl), with the entity
// names as text prompts. The protocol (one POST, JSON both ways) is described in
// services/perception/README.md, "HTTP segmentation protocol":
//
//   request  {"protocol": "dh-segment/1", "image": {"format": "png", "width": W, "height": H,
//             "data": "<base64 PNG, RGB>"}, "prompts": ["bowl", ...], "mask_format": "rle"}
//   reply    {"width": W, "height": H, "masks": [{"prompt": "bowl", "score": 0.93,
//             "rle": {"size": [H, W], "counts": [...] or "<COCO string>"}} or {..., "png": "<base64>"}]}
//
// Every failure is a SegmenterError whose message says what went wrong: the server unreachable, the
// timeout, an HTTP status other than 200 (with the start of the body), a body that is not JSON or not
// the protocol, a mask of the wrong size or that does not decode, a mask for a prompt not asked.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "dh/perception/segmenter.hpp"

namespace dh::perception {

struct SegmenterError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct HttpSegmenterConfig {
  std::string url;                ///< the full endpoint, e.g. http://127.0.0.1:8765/segment
  double timeout_s = 5.0;         ///< whole request, connect to last byte
  double connect_timeout_s = 1.0;
  std::string mask_format = "rle";  ///< what the request asks for: "rle" or "png" (the reply may use either)
  std::size_t max_reply_bytes = 64u << 20;
};

class HttpSegmenter final : public Segmenter {
 public:
  /// Throws std::invalid_argument on an empty url, a non-positive timeout or an unknown mask_format.
  explicit HttpSegmenter(HttpSegmenterConfig config);
  /// One POST per call; masks in the reply's order. Appearance colours are not sent, only the names.
  std::vector<Mask> segment(const cv::Mat& rgb, const std::vector<EntityAppearance>& entities) override;
  const HttpSegmenterConfig& config() const { return config_; }

 private:
  HttpSegmenterConfig config_;
};

/// The protocol without the transport, for tests and for servers written in C++: the request body for an
/// image and prompts, and the masks from a reply body (throws SegmenterError).
std::string make_segment_request(const cv::Mat& rgb, const std::vector<std::string>& prompts,
                                 const std::string& mask_format);
std::vector<Mask> parse_segment_reply(const std::string& body, int width, int height,
                                      const std::vector<std::string>& prompts);

}  // namespace dh::perception
