#include "dh/rtde/robotiq_socket.hpp"

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read_until.hpp>
#include <boost/asio/streambuf.hpp>
#include <boost/asio/write.hpp>
#include <cctype>
#include <charconv>
#include <sstream>
#include <thread>

#include "deadline_socket.hpp"

namespace dh::rtde {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

namespace {

/// The line's words.
std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

std::optional<int> integer(const std::string& s) {
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

std::string robotiq_fault_text(int code) {
  switch (code) {
    case 0x00: return "no fault";
    case 0x05: return "action delayed: the activation must complete first (priority fault)";
    case 0x07: return "the activation bit must be set before an action (priority fault)";
    case 0x08: return "over its operating temperature (minor fault: let it cool)";
    case 0x09: return "no communication for at least 1 s (minor fault)";
    case 0x0A: return "under its minimum operating voltage (major fault: reset needed)";
    case 0x0B: return "automatic release in progress (major fault: reset needed)";
    case 0x0C: return "internal fault (major fault: reset needed)";
    case 0x0D: return "activation fault (major fault: reset needed)";
    case 0x0E: return "overcurrent (major fault: reset needed)";
    case 0x0F: return "automatic release completed (major fault: reset needed)";
    default: return "unknown fault code";
  }
}

double robotiq_gap(int position, const RobotiqRange& range, double stroke_m) {
  const double share = static_cast<double>(range.closed - position) / (range.closed - range.open);
  return std::clamp(share, 0.0, 1.0) * stroke_m;
}

std::string robotiq_answer(const std::string& line, const std::function<bool(const std::string&, int)>& set,
                           const std::function<std::optional<int>(const std::string&)>& get) {
  const auto w = words(line);
  if (w.size() == 2 && w[0] == "GET") {
    if (const auto v = get(w[1])) return w[1] + " " + std::to_string(*v);
    return "?";
  }
  if (w.size() >= 3 && w.size() % 2 == 1 && w[0] == "SET") {
    std::vector<std::pair<std::string, int>> values;
    for (std::size_t i = 1; i < w.size(); i += 2) {
      const auto v = integer(w[i + 1]);
      if (!v) return "?";
      values.emplace_back(w[i], *v);
    }
    for (const auto& [var, v] : values)
      if (!set(var, v)) return "?";
    return "ack";
  }
  return "?";
}

// --- the client ----------------------------------------------------------------------------------------

struct RobotiqClient::Io : DeadlineSocket {
  asio::streambuf in;
};

RobotiqClient::RobotiqClient() : io_(std::make_unique<Io>()) {}
RobotiqClient::~RobotiqClient() = default;

bool RobotiqClient::connected() const { return io_->socket.is_open(); }

void RobotiqClient::close() {
  io_->close();
  io_->in.consume(io_->in.size());
}

void RobotiqClient::fail(const std::string& why) {
  close();
  throw GripperError(why);
}

void RobotiqClient::connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout) {
  close();
  bool refused = false;
  if (const auto why = io_->connect(host, port, timeout, refused))
    fail("gripper: " + *why + (refused ? " (is the Robotiq URCap installed and its server on?)" : ""));
}

std::string RobotiqClient::exchange(const std::string& line, std::chrono::milliseconds timeout) {
  if (!connected()) fail("gripper: '" + line + "' with no connection");
  boost::system::error_code ec;
  std::size_t n = 0;
  const std::string out = line + "\n";
  asio::async_write(io_->socket, asio::buffer(out),
                    [&](const boost::system::error_code& e, std::size_t) { ec = e; });
  if (!io_->run(timeout) || ec)
    fail("gripper: '" + line + "' could not be sent" + (ec ? ": " + ec.message() : ""));
  asio::async_read_until(io_->socket, io_->in, '\n', [&](const boost::system::error_code& e, std::size_t k) {
    ec = e;
    n = k;
  });
  if (!io_->run(timeout))
    fail("gripper: no answer to '" + line + "' within " + std::to_string(timeout.count()) + " ms");
  if (ec) fail("gripper: the link closed at '" + line + "': " + ec.message());
  std::string answer(asio::buffers_begin(io_->in.data()), asio::buffers_begin(io_->in.data()) + n);
  io_->in.consume(n);
  while (!answer.empty() && std::isspace(static_cast<unsigned char>(answer.back()))) answer.pop_back();
  return answer;
}

void RobotiqClient::set(const std::vector<std::pair<std::string, int>>& values,
                        std::chrono::milliseconds timeout) {
  std::string line = "SET";
  for (const auto& [var, v] : values) line += " " + var + " " + std::to_string(v);
  const std::string answer = exchange(line, timeout);
  if (answer != "ack") fail("gripper: '" + line + "' answered '" + answer + "', not 'ack'");
}

int RobotiqClient::get(const std::string& var, std::chrono::milliseconds timeout) {
  const std::string answer = exchange("GET " + var, timeout);
  const auto w = words(answer);
  const std::optional<int> v = w.size() == 2 && w[0] == var ? integer(w[1]) : std::nullopt;
  if (!v) fail("gripper: 'GET " + var + "' answered '" + answer + "', not '" + var + " <integer>'");
  return *v;
}

void RobotiqClient::activate(int force, std::chrono::milliseconds timeout) {
  set({{"ACT", 1}}, timeout);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  int status = 0;
  while ((status = get("STA", timeout)) != 3) {
    if (std::chrono::steady_clock::now() > deadline)
      fail("gripper: not active within " + std::to_string(timeout.count()) + " ms of ACT 1 (STA " +
           std::to_string(status) + "): is it powered and wired to the tool connector?");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  set({{"GTO", 1}, {"SPE", 255}, {"FOR", force}}, timeout);
}

// --- the server (test double) --------------------------------------------------------------------------

struct RobotiqServer::Impl {
  Impl(std::function<bool(const std::string&, int)> set,
       std::function<std::optional<int>(const std::string&)> get, std::uint16_t port)
      : set(std::move(set)),
        get(std::move(get)),
        acceptor(context, tcp::endpoint(asio::ip::address_v4::loopback(), port)) {}

  void accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket s) {
      if (ec) return;  // the acceptor closed: the server is stopping
      socket.emplace(std::move(s));
      in.consume(in.size());
      read_line();
    });
  }
  void read_line() {
    asio::async_read_until(*socket, in, '\n', [this](const boost::system::error_code& ec, std::size_t n) {
      if (ec) return end();
      std::string line(asio::buffers_begin(in.data()), asio::buffers_begin(in.data()) + n);
      in.consume(n);
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      answer = robotiq_answer(line, set, get) + "\n";
      asio::async_write(*socket, asio::buffer(answer),
                        [this](const boost::system::error_code& e, std::size_t) {
                          if (e) return end();
                          read_line();
                        });
    });
  }
  void end() {
    boost::system::error_code ignored;
    socket->close(ignored);
    socket.reset();
    accept();
  }

  std::function<bool(const std::string&, int)> set;
  std::function<std::optional<int>(const std::string&)> get;
  asio::io_context context;
  tcp::acceptor acceptor;
  std::optional<tcp::socket> socket;
  asio::streambuf in;
  std::string answer;
  std::thread thread;
};

RobotiqServer::RobotiqServer(std::function<bool(const std::string&, int)> set,
                             std::function<std::optional<int>(const std::string&)> get, std::uint16_t port)
    : impl_(std::make_unique<Impl>(std::move(set), std::move(get), port)) {
  port_ = impl_->acceptor.local_endpoint().port();
  impl_->accept();
  impl_->thread = std::thread([this] { impl_->context.run(); });
}

RobotiqServer::~RobotiqServer() {
  impl_->context.stop();
  impl_->thread.join();
}

}  // namespace dh::rtde
