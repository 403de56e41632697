// HttpTransport over libcurl: one easy handle per request, so concurrent requests from several threads
// are independent. Loopback endpoints never go through a proxy configured in the environment.
#pragma once

#include "dh/planner/http.hpp"

namespace dh::planner {

class CurlTransport : public HttpTransport {
 public:
  /// Initializes libcurl once per process; construct it before starting threads that use it.
  CurlTransport();
  HttpResponse post(const HttpRequest& request, const std::function<bool()>& cancelled) override;
};

}  // namespace dh::planner
