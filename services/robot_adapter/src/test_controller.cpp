#include "dh/rtde/test_controller.hpp"

#include <array>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <deque>
#include <thread>

namespace dh::rtde {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

Package ControllerCore::error(const std::string& message) {
  return text_message_package({message.substr(0, 255), "test controller", 1});
}

std::vector<Package> ControllerCore::on_package(const Package& p) {
  switch (p.type) {
    case PackageType::RequestProtocolVersion: {
      const bool ok = p.payload.size() == 2 && ((p.payload[0] << 8) | p.payload[1]) == kProtocolVersion;
      negotiated_ = ok;
      return {accepted_reply(p.type, ok)};
    }
    case PackageType::GetUrcontrolVersion:
      return {urcontrol_version_reply(model_.version)};
    case PackageType::SetupOutputs:
    case PackageType::SetupInputs: {
      if (!negotiated_) return {error(to_string(p.type) + " before the protocol version was agreed")};
      if (streaming_) return {error(to_string(p.type) + " while streaming: pause first")};
      const bool out = p.type == PackageType::SetupOutputs;
      double frequency = 0;
      const std::vector<std::string> names = setup_names(p, out ? &frequency : nullptr);
      if (out && !(frequency > 0 && frequency <= 500))
        return {error("output frequency " + std::to_string(frequency) +
                      " Hz: a controller sends at 0 < f <= 500 Hz")};
      const auto& served = out ? model_.outputs : model_.inputs;
      Recipe r{next_id_, {}, {}};
      std::vector<std::optional<FieldType>> types;
      bool complete = true;
      for (const auto& n : names) {
        const auto it = served.find(n);
        types.push_back(it == served.end() ? std::nullopt : std::optional(it->second));
        complete = complete && it != served.end();
        if (it != served.end()) {
          r.names.push_back(n);
          r.types.push_back(it->second);
        }
      }
      if (complete) {
        ++next_id_;
        if (out) {
          outputs_ = r;
          frequency_ = frequency;
        } else {
          input_recipes_[r.id] = r;
        }
      }
      return {setup_reply(p.type, complete ? r.id : 0, types)};
    }
    case PackageType::Start:
      streaming_ = outputs_.has_value() && frequency_ > 0;
      return {accepted_reply(p.type, streaming_)};
    case PackageType::Pause:
      streaming_ = false;
      return {accepted_reply(p.type, true)};
    case PackageType::DataPackage: {
      if (p.payload.empty()) return {error("a data package without a recipe id")};
      const auto it = input_recipes_.find(p.payload[0]);
      if (it == input_recipes_.end())
        return {error("a data package of input recipe " + std::to_string(p.payload[0]) +
                      ", which was never set up")};
      const std::vector<Value> values = data_values(p, it->second);
      for (std::size_t i = 0; i < values.size(); ++i) inputs_[it->second.names[i]] = values[i];
      return {};
    }
    case PackageType::TextMessage:
      return {};
  }
  return {error("a package of " + to_string(p.type) + ", which RTDE does not define")};
}

struct TestController::Impl {
  Impl(ControllerModel model, TestController::Read read, std::function<void(const std::string&)> on_script,
       std::uint16_t port, std::uint16_t script_port)
      : model(std::move(model)),
        read(std::move(read)),
        on_script(std::move(on_script)),
        acceptor(context, tcp::endpoint(asio::ip::make_address("127.0.0.1"), port)),
        script_acceptor(context, tcp::endpoint(asio::ip::make_address("127.0.0.1"), script_port)) {}

  /// One script connection at a time: its bytes up to the client's close are the program.
  void accept_script() {
    script_acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket s) {
      if (ec) return;
      script_socket.emplace(std::move(s));
      script.clear();
      read_script();
    });
  }

  void read_script() {
    script_socket->async_read_some(asio::buffer(buffer_script),
                                   [this](const boost::system::error_code& ec, std::size_t n) {
                                     script.append(reinterpret_cast<const char*>(buffer_script.data()), n);
                                     if (!ec && script.size() < kMaxScriptBytes) return read_script();
                                     if (ec == asio::error::eof && on_script) on_script(script);
                                     script_socket.reset();
                                     accept_script();
                                   });
  }

  // Every handler below runs on the controller's thread and carries the session it was started in: one
  // that completes after its session ended (a dropped client, a new one accepted) does nothing.

  void accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket s) {
      if (ec) return;  // the acceptor closed: the controller is stopping
      std::lock_guard lock(mutex);
      ++session;
      socket.emplace(std::move(s));
      boost::system::error_code ignored;
      socket->set_option(tcp::no_delay(true), ignored);
      core.emplace(model);
      reader = PackageReader{};
      sent = 0;
      read_some(session);
    });
  }

  bool current(std::uint64_t id) const { return id == session && socket.has_value(); }

  void read_some(std::uint64_t id) {
    socket->async_read_some(
        asio::buffer(buffer), [this, id](const boost::system::error_code& ec, std::size_t n) {
          if (!current(id)) return;
          if (ec) return end_session(id);
          std::vector<Package> replies;
          bool rtde = true, started = false;
          {
            std::lock_guard lock(mutex);
            reader.feed(std::span(buffer.data(), n));
            try {
              while (auto p = reader.next()) {
                if (silent) continue;
                const bool was_streaming = core->streaming();
                for (auto& r : core->on_package(*p)) replies.push_back(std::move(r));
                started = started || (core->streaming() && !was_streaming);
              }
            } catch (const ProtocolError&) {
              rtde = false;
            }
          }
          if (!rtde) return end_session(id);  // bytes that are not RTDE: a controller drops such a client
          for (auto& r : replies) send(id, std::move(r));
          if (started) schedule_output(id, std::chrono::steady_clock::now());
          read_some(id);
        });
  }

  void schedule_output(std::uint64_t id, std::chrono::steady_clock::time_point at) {
    timer.expires_at(at);
    timer.async_wait([this, id, at](const boost::system::error_code& ec) {
      if (ec || !current(id)) return;
      Recipe recipe;
      double frequency = 0;
      bool quiet = false;
      {
        std::lock_guard lock(mutex);
        if (!core->streaming()) return;
        recipe = *core->output_recipe();
        frequency = core->frequency();
        quiet = silent;
      }
      if (!quiet) {
        // The caller's values, read without the lock (its `read` may ask for the inputs).
        try {
          send(id, data_package(recipe, read(recipe.names)));
        } catch (const std::exception&) {
          return end_session(id);  // a value the recipe cannot carry: the session cannot go on
        }
        std::lock_guard lock(mutex);
        ++sent;
      }
      schedule_output(id, at + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(1.0 / frequency)));
    });
  }

  void send(std::uint64_t id, Package p) {
    const bool idle = writes.empty();
    writes.push_back(encode(p));
    if (idle) write_front(id);
  }

  void write_front(std::uint64_t id) {
    asio::async_write(*socket, asio::buffer(writes.front()),
                      [this, id](const boost::system::error_code& ec, std::size_t) {
                        if (!current(id)) return;
                        if (ec) return end_session(id);
                        writes.pop_front();
                        if (!writes.empty()) write_front(id);
                      });
  }

  void end_session(std::uint64_t id) {
    if (!current(id)) return;
    std::lock_guard lock(mutex);
    boost::system::error_code ignored;
    socket->close(ignored);
    socket.reset();
    timer.cancel();
    writes.clear();
    accept();
  }

  static constexpr std::size_t kMaxScriptBytes = 1 << 20;  ///< longer is not a program we sent
  ControllerModel model;
  TestController::Read read;
  std::function<void(const std::string&)> on_script;
  asio::io_context context;
  tcp::acceptor acceptor, script_acceptor;
  std::optional<tcp::socket> script_socket;
  std::string script;
  std::array<std::uint8_t, 4096> buffer_script{};
  asio::steady_timer timer{context};
  std::optional<tcp::socket> socket;
  std::optional<ControllerCore> core;
  PackageReader reader;
  std::array<std::uint8_t, 4096> buffer{};
  std::deque<std::vector<std::uint8_t>> writes;  ///< the controller's thread only
  std::uint64_t session = 0;                     ///< accepted connections; the controller's thread only
  mutable std::mutex mutex;                      ///< core, sent, silent: read from the caller's thread
  std::size_t sent = 0;
  bool silent = false;
  std::thread thread;
};

TestController::TestController(ControllerModel model, Read read,
                               std::function<void(const std::string&)> on_script, std::uint16_t port,
                               std::uint16_t script_port)
    : impl_(std::make_unique<Impl>(std::move(model), std::move(read), std::move(on_script), port,
                                   script_port)) {
  port_ = impl_->acceptor.local_endpoint().port();
  script_port_ = impl_->script_acceptor.local_endpoint().port();
  impl_->accept();
  impl_->accept_script();
  impl_->thread = std::thread([this] { impl_->context.run(); });
}

TestController::~TestController() {
  impl_->context.stop();
  impl_->thread.join();
}

std::map<std::string, Value> TestController::inputs() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->core ? impl_->core->inputs() : std::map<std::string, Value>{};
}

std::size_t TestController::outputs_sent() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->sent;
}

void TestController::set_silent(bool silent) {
  std::lock_guard lock(impl_->mutex);
  impl_->silent = silent;
}

void TestController::drop_client() {
  asio::post(impl_->context, [this] { impl_->end_session(impl_->session); });
}

}  // namespace dh::rtde
