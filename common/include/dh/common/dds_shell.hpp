// The one DDS shell (docs/one-dds-shell.md): it runs a service core from a binding that names the core's
// ports by their tags (ports.hpp), so readers, writers, the event queue, the managed lifecycle and
// liveliness are written once here and not per service.
//
// A binding B provides:
//   std::string name() const                       the service's name ("dh_planner"), its logger's too
//   std::string description() const                  one line for --help
//   const Ports& ports() const                       its core's declared ports: Inputs and Outputs must be
//                                                    the same topics, or configure fails naming the difference
//   using Inputs = dds::Inputs<In<port::X>, In<port::Y, kLiveliness>, ...>
//   using Outputs = dds::Outputs<port::Z, ...>
//   void options(CLI::App&)                          its command-line options
//   void configure(Context<B>&)                      reads its own configuration, makes its core
//   void on(const Sample<port::X>&, Context<B>&)     one per input: a missing one does not compile
// and, when it needs them:
//   void on(const LivelinessChanged<port::Y>&, Context<B>&)   inputs flagged kLiveliness
//   void on(const DeadlineMissed<port::Y>&, Context<B>&)      inputs flagged kDeadline
//   void parsed()                       checks the options together (throws to refuse them: exit 2)
//   void activate(Context<B>&)          after the readers are made (announce here)
//   void tick(Context<B>&)              after every turn of the loop
//   std::chrono::milliseconds wait()    how long a turn waits for an event (default 50 ms)
//   void drain(Context<B>&), bool drained()   take no new work; true once what runs has finished
//   std::chrono::milliseconds drain_timeout()
//   std::chrono::milliseconds loop_allowance()   liveliness is asserted while the loop turned within it
//   void deactivate(Context<B>&), void shutdown()
//
// Listeners run on Fast DDS's threads and only push into the queue; every handler, and every write, runs on
// the loop's thread. Work on other threads comes back with Context::post.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <type_traits>
#include <variant>

#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/ports.hpp"
#include "dh/common/service.hpp"

namespace dh::dds {

/// What an input needs beyond its samples.
enum InputFlags : unsigned {
  kPlain = 0,
  kLiveliness = 1,  ///< LivelinessChanged events (a writer's lease kept or lost)
  kDeadline = 2,    ///< DeadlineMissed events
  kSkipOwn = 4,     ///< samples this process wrote itself (the tag is also an output) are dropped
};

template <class Tag, unsigned F = kPlain>
struct In {
  using tag = Tag;
  static constexpr unsigned flags = F;
};
template <class... I>
struct Inputs {};
template <class... Tags>
struct Outputs {};

template <class Tag>
using Msg = typename Tag::Msg;

template <class Tag>
struct Sample {
  Msg<Tag> msg;
  fdds::InstanceHandle_t writer;  ///< who wrote it (SampleInfo::publication_handle)
};
template <class Tag>
struct LivelinessChanged {
  fdds::InstanceHandle_t writer;
  bool alive;
};
template <class Tag>
struct DeadlineMissed {
  fdds::InstanceHandle_t instance;
};

namespace detail {

template <class Tag, class... Tags>
inline constexpr bool contains = (std::is_same_v<Tag, Tags> || ...);

template <class Tag>
struct WriterSlot {
  std::optional<Writer<typename Tag::PubSub>> writer;
};

template <class Out>
class Emit;
template <class... Tags>
class Emit<Outputs<Tags...>> {
 public:
  void open(Participant& p) { (std::get<WriterSlot<Tags>>(slots_).writer.emplace(p, std::string(Tags::topic), Tags::qos), ...); }
  void close() { (std::get<WriterSlot<Tags>>(slots_).writer.reset(), ...); }
  template <class Tag>
  Writer<typename Tag::PubSub>& get() {
    static_assert(contains<Tag, Tags...>, "not an output of this service");
    return *std::get<WriterSlot<Tag>>(slots_).writer;
  }
  /// Asserts the liveliness of every output whose QoS has a manual liveliness lease.
  void assert_liveliness() {
    (
        [&] {
          if constexpr (Tags::qos == Qos::Announce || Tags::qos == Qos::ChannelStatus)
            if (auto& w = std::get<WriterSlot<Tags>>(slots_).writer) w->assert_liveliness();
        }(),
        ...);
  }

 private:
  std::tuple<WriterSlot<Tags>...> slots_;
};

template <class In>
struct ReaderSlot {
  std::optional<Reader<typename In::tag::PubSub>> reader;
};

/// Every event the loop can be handed: each input's samples and QoS events, and posted work.
template <class Ins>
struct EventsOf;
template <class... I>
struct EventsOf<Inputs<I...>> {
  using type = std::variant<Sample<typename I::tag>..., LivelinessChanged<typename I::tag>...,
                            DeadlineMissed<typename I::tag>..., std::function<void()>>;
};

}  // namespace detail

template <class B>
class Shell;

/// What a binding's handlers see: the writers, the logger, and a way back onto the loop's thread.
template <class B>
class Context {
 public:
  using Event = typename detail::EventsOf<typename B::Inputs>::type;

  explicit Context(spdlog::logger& log) : log(log) {}

  template <class Tag>
  bool write(const Msg<Tag>& m) {
    return emit_.template get<Tag>().write(m);
  }
  template <class Tag>
  Writer<typename Tag::PubSub>& writer() {
    return emit_.template get<Tag>();
  }
  /// Runs `work` on the loop's thread at its next turn (results of work done on other threads).
  void post(std::function<void()> work) { queue_.push(std::move(work)); }
  Participant& participant() { return *participant_; }

  spdlog::logger& log;

 private:
  template <class>
  friend class Shell;
  std::optional<Participant> participant_;
  detail::Emit<typename B::Outputs> emit_;
  EventQueue<Event> queue_;
};

template <class B>
class Shell {
 public:
  Shell(B& binding, spdlog::logger& log) : b_(binding), ctx_(log) {}

  int run() {
    ManagedService m;
    m.transitions.configure = [this] {
      check_ports();
      b_.configure(ctx_);
      ctx_.participant_.emplace(b_.name());
      ctx_.emit_.open(*ctx_.participant_);
    };
    m.transitions.activate = [this] {
      open_readers(typename B::Inputs{});
      if constexpr (requires { b_.activate(ctx_); }) b_.activate(ctx_);
      beat();
      heartbeat_.emplace([this] { if (loop_turned_within(allowance())) ctx_.emit_.assert_liveliness(); },
                         assert_every());
    };
    m.transitions.drain = [this] {
      if constexpr (requires { b_.drain(ctx_); }) b_.drain(ctx_);
    };
    m.transitions.deactivate = [this] {
      heartbeat_.reset();
      close_readers(typename B::Inputs{});
      if constexpr (requires { b_.deactivate(ctx_); }) b_.deactivate(ctx_);
    };
    m.transitions.shutdown = [this] {
      heartbeat_.reset();
      close_readers(typename B::Inputs{});
      if constexpr (requires { b_.shutdown(); }) b_.shutdown();
      ctx_.emit_.close();
      ctx_.participant_.reset();
    };
    m.step = [this] { turn(); };
    if constexpr (requires { b_.drained(); }) {
      m.drained = [this] { return b_.drained(); };
      m.drain_timeout = b_.drain_timeout();
    }
    return run_managed(ctx_.log, std::move(m));
  }

 private:
  static std::chrono::milliseconds assert_every() {
    return std::chrono::milliseconds(static_cast<int>(kLivelinessLeaseSec * 1000 / 4));
  }
  std::chrono::milliseconds allowance() {
    if constexpr (requires { b_.loop_allowance(); }) return std::max(assert_every(), b_.loop_allowance());
    return assert_every();
  }
  /// The topics the binding reads and writes are those its core declares.
  void check_ports() const {
    std::set<std::string> wired, declared;
    wire(typename B::Inputs{}, wired);
    wire(typename B::Outputs{}, wired);
    for (const Port& p : b_.ports())
      declared.insert((p.direction == PortDirection::In ? "in " : "out ") + std::string(p.topic));
    std::string diff;
    for (const auto& w : wired)
      if (!declared.count(w)) diff += " wired, not declared: " + w + ";";
    for (const auto& d : declared)
      if (!wired.count(d)) diff += " declared, not wired: " + d + ";";
    if (!diff.empty()) throw std::logic_error(b_.name() + ": its ports differ from its core's declaration:" + diff);
  }
  template <class... I>
  static void wire(Inputs<I...>, std::set<std::string>& into) {
    (into.insert("in " + std::string(I::tag::topic)), ...);
  }
  template <class... Tags>
  static void wire(Outputs<Tags...>, std::set<std::string>& into) {
    (into.insert("out " + std::string(Tags::topic)), ...);
  }

  void beat() { beat_ = std::chrono::steady_clock::now().time_since_epoch().count(); }
  bool loop_turned_within(std::chrono::milliseconds d) const {
    using C = std::chrono::steady_clock;
    return C::now() - C::time_point(C::duration(beat_.load())) <= d;
  }

  void turn() {
    std::chrono::milliseconds wait{50};
    if constexpr (requires { b_.wait(); }) wait = b_.wait();
    if (auto e = ctx_.queue_.pop(wait)) std::visit([this](auto& ev) { dispatch(ev); }, *e);
    if constexpr (requires { b_.tick(ctx_); }) b_.tick(ctx_);
    beat();
  }

  void dispatch(std::function<void()>& work) { work(); }
  template <class Tag>
  void dispatch(Sample<Tag>& s) {
    b_.on(s, ctx_);
  }
  template <class Tag>
  void dispatch(LivelinessChanged<Tag>& e) {
    if constexpr (requires { b_.on(e, ctx_); }) b_.on(e, ctx_);
  }
  template <class Tag>
  void dispatch(DeadlineMissed<Tag>& e) {
    if constexpr (requires { b_.on(e, ctx_); }) b_.on(e, ctx_);
  }

  template <class... I>
  void open_readers(Inputs<I...>) {
    (open_reader<I>(), ...);
  }
  template <class... I>
  void close_readers(Inputs<I...>) {
    (std::get<detail::ReaderSlot<I>>(readers_).reader.reset(), ...);
  }
  template <class I>
  void open_reader() {
    using Tag = typename I::tag;
    using R = Reader<typename Tag::PubSub>;
    static_assert(requires(B& b, Sample<Tag>& s, Context<B>& c) { b.on(s, c); }, "the binding has no handler for an input");
    typename R::Callbacks cb;
    auto& q = ctx_.queue_;
    std::optional<fdds::InstanceHandle_t> own;
    if constexpr ((I::flags & kSkipOwn) != 0) own = ctx_.emit_.template get<Tag>().handle();
    cb.on_data = [&q, own](const Msg<Tag>& m, const fdds::SampleInfo& info) {
      if (own && info.publication_handle == *own) return;
      q.push(Sample<Tag>{m, info.publication_handle});
    };
    if constexpr ((I::flags & kLiveliness) != 0)
      cb.on_liveliness = [&q](const fdds::LivelinessChangedStatus& s) {
        // Lost: an alive writer turned not alive (its lease expired) or went away (its participant's lease
        // expired, or it was deleted).
        if (s.not_alive_count_change > 0 || s.alive_count_change < 0)
          q.push(LivelinessChanged<Tag>{s.last_publication_handle, false});
        if (s.alive_count_change > 0) q.push(LivelinessChanged<Tag>{s.last_publication_handle, true});
      };
    if constexpr ((I::flags & kDeadline) != 0)
      cb.on_deadline = [&q](const fdds::RequestedDeadlineMissedStatus& s) {
        q.push(DeadlineMissed<Tag>{s.last_instance_handle});
      };
    std::get<detail::ReaderSlot<I>>(readers_).reader.emplace(*ctx_.participant_, std::string(Tag::topic), Tag::qos,
                                                             std::move(cb));
  }

  template <class Ins>
  struct ReaderSlots;
  template <class... I>
  struct ReaderSlots<Inputs<I...>> {
    using type = std::tuple<detail::ReaderSlot<I>...>;
  };

  B& b_;
  Context<B> ctx_;  // before the readers, whose listeners push into its queue
  typename ReaderSlots<typename B::Inputs>::type readers_;
  std::optional<Heartbeat> heartbeat_;
  std::atomic<std::chrono::steady_clock::rep> beat_{0};
};

/// A service process's whole `main`: parses the binding's options, then runs its lifecycle.
template <class B>
int run_service(int argc, char** argv, B binding = {}) {
  CLI::App app{binding.name() + ": " + binding.description()};
  binding.options(app);
  CLI11_PARSE(app, argc, argv);
  if constexpr (requires { binding.parsed(); }) {
    try {
      binding.parsed();
    } catch (const std::exception& e) {
      std::cerr << binding.name() << ": " << e.what() << "\n";
      return 2;
    }
  }
  auto log = make_logger(binding.name());
  return Shell<B>(binding, *log).run();
}

}  // namespace dh::dds
