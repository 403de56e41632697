#include "dh/perception/http_segmenter.hpp"

#include <curl/curl.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace dh::perception {

namespace {

using nlohmann::json;

constexpr const char* kProtocol = "dh-segment/1";

std::string excerpt(const std::string& s, std::size_t n = 200) {
  std::string e = s.substr(0, n);
  std::replace(e.begin(), e.end(), '\n', ' ');
  return s.size() > n ? e + "..." : e;
}

Mask mask_from_json(const json& m, std::size_t index, int width, int height,
                    const std::vector<std::string>& prompts) {
  const std::string where = "segmentation reply: mask " + std::to_string(index);
  if (!m.is_object()) throw SegmenterError(where + " is not an object");
  if (!m.contains("prompt") || !m["prompt"].is_string())
    throw SegmenterError(where + " has no \"prompt\" string");
  Mask out;
  out.entity = m["prompt"].get<std::string>();
  if (std::find(prompts.begin(), prompts.end(), out.entity) == prompts.end())
    throw SegmenterError(where + " is for \"" + out.entity + "\", which was not asked");
  out.score = 1.0;
  if (m.contains("score")) {
    if (!m["score"].is_number()) throw SegmenterError(where + ": \"score\" is not a number");
    out.score = m["score"].get<double>();
    if (!(out.score >= 0 && out.score <= 1))
      throw SegmenterError(where + ": score " + std::to_string(out.score) + " is outside [0, 1]");
  }
  const bool has_rle = m.contains("rle"), has_png = m.contains("png");
  if (has_rle == has_png) throw SegmenterError(where + " must carry exactly one of \"rle\" and \"png\"");
  try {
    if (has_png) {
      if (!m["png"].is_string()) throw SegmenterError(where + ": \"png\" is not a base64 string");
      out.pixels = decode_png_base64_mask(m["png"].get_ref<const std::string&>(), width, height);
      return out;
    }
    const json& rle = m["rle"];
    if (!rle.is_object() || !rle.contains("size") || !rle.contains("counts"))
      throw SegmenterError(where + ": \"rle\" must be an object with \"size\" and \"counts\"");
    const json& size = rle["size"];
    if (!size.is_array() || size.size() != 2 || !size[0].is_number_integer() || !size[1].is_number_integer())
      throw SegmenterError(where + ": rle \"size\" must be [height, width]");
    const int h = size[0].get<int>(), w = size[1].get<int>();
    if (h != height || w != width)
      throw SegmenterError(where + ": size mismatch, the mask is " + std::to_string(w) + "x" + std::to_string(h) +
                           " (rle size is [height, width]), the image is " + std::to_string(width) + "x" +
                           std::to_string(height));
    const json& counts = rle["counts"];
    if (counts.is_string()) {
      out.pixels = decode_coco_rle_string(counts.get_ref<const std::string&>(), width, height);
    } else if (counts.is_array()) {
      std::vector<std::int64_t> c;
      c.reserve(counts.size());
      for (const json& v : counts) {
        if (!v.is_number_integer()) throw SegmenterError(where + ": rle counts must be integers");
        c.push_back(v.get<std::int64_t>());
      }
      out.pixels = decode_rle(c, width, height);
    } else {
      throw SegmenterError(where + ": rle \"counts\" must be an array or a COCO string");
    }
  } catch (const MaskDecodeError& e) {
    throw SegmenterError(where + ": " + e.what());
  }
  return out;
}

std::once_flag curl_once;

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

struct Sink {
  std::string body;
  std::size_t max_bytes = 0;
  bool overflow = false;
};

size_t on_body(char* data, size_t size, size_t count, void* user) {
  auto* sink = static_cast<Sink*>(user);
  const std::size_t n = size * count;
  if (sink->body.size() + n > sink->max_bytes) {
    sink->overflow = true;
    return 0;  // curl aborts the transfer with a write error
  }
  sink->body.append(data, n);
  return n;
}

}  // namespace

std::string make_segment_request(const cv::Mat& rgb, const std::vector<std::string>& prompts,
                                 const std::string& mask_format) {
  if (rgb.empty() || rgb.type() != CV_8UC3)
    throw std::invalid_argument("segment request: the image must be a non-empty CV_8UC3 (RGB)");
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);  // imencode writes BGR as the PNG's RGB
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", bgr, png, {cv::IMWRITE_PNG_COMPRESSION, 1}))
    throw std::runtime_error("segment request: PNG encoding failed");
  const json body = {
      {"protocol", kProtocol},
      {"image",
       {{"format", "png"},
        {"width", rgb.cols},
        {"height", rgb.rows},
        {"data", base64_encode(std::string_view(reinterpret_cast<const char*>(png.data()), png.size()))}}},
      {"prompts", prompts},
      {"mask_format", mask_format}};
  return body.dump();
}

std::vector<Mask> parse_segment_reply(const std::string& body, int width, int height,
                                      const std::vector<std::string>& prompts) {
  json reply;
  try {
    reply = json::parse(body);
  } catch (const json::parse_error& e) {
    throw SegmenterError("segmentation reply is not JSON (" + std::string(e.what()) + "): " + excerpt(body));
  }
  if (!reply.is_object()) throw SegmenterError("segmentation reply is not a JSON object: " + excerpt(body));
  if (reply.contains("error"))
    throw SegmenterError("segmentation server reports an error: " + excerpt(reply["error"].dump()));
  if (reply.contains("width") && reply.contains("height")) {
    if (!reply["width"].is_number_integer() || !reply["height"].is_number_integer())
      throw SegmenterError("segmentation reply: width and height must be integers");
    const int w = reply["width"].get<int>(), h = reply["height"].get<int>();
    if (w != width || h != height)
      throw SegmenterError("segmentation reply: size mismatch, the reply is for " + std::to_string(w) + "x" +
                           std::to_string(h) + ", the image is " + std::to_string(width) + "x" +
                           std::to_string(height));
  }
  if (!reply.contains("masks") || !reply["masks"].is_array())
    throw SegmenterError("segmentation reply has no \"masks\" array: " + excerpt(body));
  std::vector<Mask> out;
  out.reserve(reply["masks"].size());
  std::size_t i = 0;
  for (const json& m : reply["masks"]) out.push_back(mask_from_json(m, i++, width, height, prompts));
  return out;
}

HttpSegmenter::HttpSegmenter(HttpSegmenterConfig config) : config_(std::move(config)) {
  if (config_.url.empty()) throw std::invalid_argument("http segmenter: no url");
  if (!(config_.timeout_s > 0) || !(config_.connect_timeout_s > 0))
    throw std::invalid_argument("http segmenter: timeouts must be positive");
  if (config_.mask_format != "rle" && config_.mask_format != "png")
    throw std::invalid_argument("http segmenter: mask_format must be \"rle\" or \"png\", not \"" +
                                config_.mask_format + "\"");
  std::call_once(curl_once, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
}

std::vector<Mask> HttpSegmenter::segment(const cv::Mat& rgb, const std::vector<EntityAppearance>& entities) {
  std::vector<std::string> prompts;
  prompts.reserve(entities.size());
  for (const EntityAppearance& e : entities) prompts.push_back(e.entity);
  const std::string request = make_segment_request(rgb, prompts, config_.mask_format);

  std::unique_ptr<CURL, decltype(&curl_easy_cleanup)> curl(curl_easy_init(), &curl_easy_cleanup);
  if (!curl) throw SegmenterError("http segmenter: curl_easy_init failed");
  std::unique_ptr<curl_slist, decltype(&curl_slist_free_all)> headers(
      curl_slist_append(curl_slist_append(nullptr, "Content-Type: application/json"), "Expect:"),
      &curl_slist_free_all);
  Sink sink;
  sink.max_bytes = config_.max_reply_bytes;
  const std::string& body = sink.body;
  char error[CURL_ERROR_SIZE] = {0};
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_URL, config_.url.c_str());
  curl_easy_setopt(c, CURLOPT_POST, 1L);
  curl_easy_setopt(c, CURLOPT_POSTFIELDS, request.data());
  curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(request.size()));
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers.get());
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, &on_body);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &sink);
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, error);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, static_cast<long>(config_.timeout_s * 1000));
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, static_cast<long>(config_.connect_timeout_s * 1000));
  const CURLcode rc = curl_easy_perform(c);
  if (rc != CURLE_OK) {
    std::string why = error[0] ? error : curl_easy_strerror(rc);
    if (rc == CURLE_OPERATION_TIMEDOUT)
      why = "timed out after " + seconds(config_.timeout_s) + " s (" + why + ")";
    else if (rc == CURLE_COULDNT_CONNECT)
      why = "unreachable (" + why + ")";
    else if (sink.overflow)
      why = "reply larger than " + std::to_string(config_.max_reply_bytes) + " bytes";
    throw SegmenterError("http segmenter: POST " + config_.url + ": " + why);
  }
  long status = 0;
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &status);
  if (status != 200)
    throw SegmenterError("http segmenter: POST " + config_.url + ": HTTP " + std::to_string(status) + ": " +
                         excerpt(body));
  try {
    return parse_segment_reply(body, rgb.cols, rgb.rows, prompts);
  } catch (const SegmenterError& e) {
    throw SegmenterError("http segmenter: POST " + config_.url + ": " + e.what());
  }
}

}  // namespace dh::perception
