// The HTTP round trip a model backend needs, behind an interface: the planner node uses the libcurl
// transport (curl_transport.hpp); unit tests script replies without a network.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace dh::planner {

struct HttpRequest {
  std::string url;
  std::string body;                  ///< sent as application/json
  std::vector<std::string> headers;  ///< extra "Name: value" lines (e.g. Authorization)
  std::chrono::milliseconds timeout{90000};
};

struct HttpResponse {
  enum class Failure {
    None,       ///< a response arrived (any status)
    Connect,    ///< nothing accepted the connection (refused, unreachable, name not resolved)
    Timeout,    ///< no complete response within the timeout
    Cancelled,  ///< the caller's cancel predicate held
    Other,      ///< any other transport error
  };
  Failure failure = Failure::None;
  std::string error;  ///< the transport's message when failure != None
  long status = 0;    ///< HTTP status when failure == None
  std::string body;
};

class HttpTransport {
 public:
  virtual ~HttpTransport() = default;
  /// POSTs `request`; never throws for network conditions. `cancelled` (may be empty) is polled while
  /// the transfer waits, at least about once a second.
  virtual HttpResponse post(const HttpRequest& request, const std::function<bool()>& cancelled) = 0;
};

}  // namespace dh::planner
