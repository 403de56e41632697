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
// Lanes (the simulator worker: one workcell per channel, each with its own OpenGL context, so its own
// thread). A binding that has them also provides:
//   using Lane = ...                                  the type holding one lane's handlers
//   unsigned lanes() const, Lane& lane(unsigned)      how many (fixed at configure) and each one
//   std::optional<unsigned> lane_of(const Msg<port::X>&) const   for each input a lane handles: which
//                                                    lane a sample goes to; nullopt: no lane's, handed to
//                                                    the binding's own on() if it has one, else dropped
// and the Lane:
//   void on(const Sample<port::X>&, Context<B>&)     for every input the binding routes
//   void on(const DeadlineMissed<port::X>&, Context<B>&)   optional: a routed input's deadline, to every lane
//   void enter(Context<B>&), void leave(Context<B>&) optional: first and last on the lane's thread
//   void tick(Context<B>&)                           optional: after every turn of the lane's loop
// Each lane pops its own queue on its own thread. Liveliness is asserted only while the loop and every lane
// have turned within the allowance.
//
// Listeners run on Fast DDS's threads and only push into a queue (lane_of runs there too, so it may read
// only what configure fixed); every handler runs on its loop's or its lane's thread, and the binding's
// handlers and posted work on the loop's. Work on other threads comes back with Context::post.
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <concepts>
#include <exception>
#include <mutex>
#include <functional>
#include <optional>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <type_traits>
#include <variant>
#include <vector>

#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/ports.hpp"
#include "dh/common/service.hpp"
#include "dh/common/shutdown.hpp"

namespace dh::dds {

/// What an input needs beyond its samples.
enum InputFlags : unsigned {
  kPlain = 0,
  kLiveliness = 1,  ///< LivelinessChanged events (a writer's lease kept or lost)
  kDeadline = 2,    ///< DeadlineMissed events
  kSkipOwn = 4,     ///< samples this process wrote itself (the tag is also an output) are dropped
  kAddressed = 8,   ///< only the samples for this process or for everyone (observations: dds_addressee.hpp)
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

/// The lane type of a binding that has lanes (NoLane otherwise).
struct NoLane {};
template <class B>
struct LaneOf {
  using type = NoLane;
};
template <class B>
  requires requires { typename B::Lane; }
struct LaneOf<B> {
  using type = typename B::Lane;
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
  /// Runs `work` on the loop's thread at its next turn (results of work done on other threads, or a lane's).
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
  using Lane = typename detail::LaneOf<B>::type;
  static constexpr bool kHasLanes = !std::is_same_v<Lane, detail::NoLane>;
  using Event = typename Context<B>::Event;
  using Clock = std::chrono::steady_clock;

  /// When a loop last turned (steady clock ticks), read by the heartbeat's thread.
  struct Beat {
    std::atomic<Clock::rep> at{0};
    void now() { at = Clock::now().time_since_epoch().count(); }
    bool within(std::chrono::milliseconds d) const {
      return Clock::now() - Clock::time_point(Clock::duration(at.load())) <= d;
    }
  };
  struct LaneLoop {
    EventQueue<Event> queue;
    Beat beat;
    std::thread thread;
  };

 public:
  Shell(B& binding, spdlog::logger& log) : b_(binding), ctx_(log) {}

  int run() {
    ManagedService m;
    m.transitions.configure = [this] {
      check_ports();
      b_.configure(ctx_);
      ctx_.participant_.emplace(b_.name());
      ctx_.emit_.open(*ctx_.participant_);
      if constexpr (kHasLanes)
        for (unsigned i = 0; i < b_.lanes(); ++i) lanes_.push_back(std::make_unique<LaneLoop>());
    };
    m.transitions.activate = [this] {
      beat_.now();
      start_lanes();
      open_readers(typename B::Inputs{});
      if constexpr (requires { b_.activate(ctx_); }) b_.activate(ctx_);
      heartbeat_.emplace([this] { if (all_turned_within(allowance())) ctx_.emit_.assert_liveliness(); },
                         assert_every());
    };
    m.transitions.drain = [this] {
      if constexpr (requires { b_.drain(ctx_); }) b_.drain(ctx_);
    };
    m.transitions.deactivate = [this] {
      heartbeat_.reset();
      close_readers(typename B::Inputs{});
      stop_lanes();
      if constexpr (requires { b_.deactivate(ctx_); }) b_.deactivate(ctx_);
    };
    m.transitions.shutdown = [this] {
      heartbeat_.reset();
      close_readers(typename B::Inputs{});
      stop_lanes();
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
  /// How long a turn of the loop or of a lane waits for an event.
  std::chrono::milliseconds wait() {
    if constexpr (requires { b_.wait(); }) return b_.wait();
    return std::chrono::milliseconds(50);
  }
  std::chrono::milliseconds allowance() {
    if constexpr (requires { b_.loop_allowance(); }) return std::max(assert_every(), b_.loop_allowance());
    return assert_every();
  }
  bool all_turned_within(std::chrono::milliseconds d) const {
    if (!beat_.within(d)) return false;
    for (const auto& l : lanes_)
      if (!l->beat.within(d)) return false;
    return true;
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

  void turn() {
    if constexpr (kHasLanes) {
      std::lock_guard l(lane_failure_mutex_);
      if (lane_failure_) std::rethrow_exception(lane_failure_);
    }
    if (auto e = ctx_.queue_.pop(wait())) std::visit([this](auto& ev) { dispatch(ev); }, *e);
    if constexpr (requires { b_.tick(ctx_); }) b_.tick(ctx_);
    beat_.now();
  }

  void dispatch(std::function<void()>& work) { work(); }
  template <class Tag>
  void dispatch(Sample<Tag>& s) {
    if constexpr (requires { b_.on(s, ctx_); }) b_.on(s, ctx_);
  }
  template <class Tag>
  void dispatch(LivelinessChanged<Tag>& e) {
    if constexpr (requires { b_.on(e, ctx_); }) b_.on(e, ctx_);
  }
  template <class Tag>
  void dispatch(DeadlineMissed<Tag>& e) {
    if constexpr (requires { b_.on(e, ctx_); }) b_.on(e, ctx_);
  }

  // A lane's loop, on its own thread. An exception there ends the lane, and the loop rethrows it: the process
  // ends with it as the reason.
  void start_lanes() {
    if constexpr (kHasLanes)
      for (unsigned i = 0; i < lanes_.size(); ++i) {
        lanes_[i]->beat.now();
        lanes_[i]->thread = std::thread([this, i] { run_lane(i); });
      }
  }
  void stop_lanes() {
    lanes_stop_ = true;
    for (auto& l : lanes_)
      if (l->thread.joinable()) l->thread.join();
    lanes_stop_ = false;
  }
  void run_lane(unsigned i) {
    if constexpr (kHasLanes) {
      Lane& lane = b_.lane(i);
      LaneLoop& loop = *lanes_[i];
      try {
        if constexpr (requires { lane.enter(ctx_); }) lane.enter(ctx_);
        while (!lanes_stop_ && !shutdown_requested()) {
          if (auto e = loop.queue.pop(wait())) std::visit([&](auto& ev) { dispatch_lane(lane, ev); }, *e);
          if constexpr (requires { lane.tick(ctx_); }) lane.tick(ctx_);
          loop.beat.now();
        }
      } catch (...) {
        std::lock_guard l(lane_failure_mutex_);
        if (!lane_failure_) lane_failure_ = std::current_exception();
      }
      if constexpr (requires { lane.leave(ctx_); }) lane.leave(ctx_);
    }
  }
  template <class Ev>
  void dispatch_lane(Lane& lane, Ev& ev) {
    if constexpr (requires { lane.on(ev, ctx_); }) lane.on(ev, ctx_);
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
    constexpr bool own_handler = requires(B& b, Sample<Tag>& s, Context<B>& c) { b.on(s, c); };
    constexpr bool routed = requires(const B& b, const Msg<Tag>& m) {
      { b.lane_of(m) } -> std::same_as<std::optional<unsigned>>;
    };
    if constexpr (routed)
      static_assert(requires(Lane& l, Sample<Tag>& s, Context<B>& c) { l.on(s, c); },
                    "the binding routes an input to its lanes, whose Lane has no handler for it");
    else
      static_assert(own_handler, "the binding has no handler for an input");
    if constexpr ((I::flags & kLiveliness) != 0)
      static_assert(requires(B& b, LivelinessChanged<Tag>& e, Context<B>& c) { b.on(e, c); },
                    "an input flagged kLiveliness needs the binding's on(const LivelinessChanged<Tag>&, Context&)");
    constexpr bool lane_deadline = routed && requires(Lane& l, DeadlineMissed<Tag>& e, Context<B>& c) { l.on(e, c); };
    if constexpr ((I::flags & kDeadline) != 0)
      static_assert(lane_deadline || requires(B& b, DeadlineMissed<Tag>& e, Context<B>& c) { b.on(e, c); },
                    "an input flagged kDeadline needs an on(const DeadlineMissed<Tag>&, Context&)");
    typename R::Callbacks cb;
    auto& q = ctx_.queue_;
    std::optional<fdds::InstanceHandle_t> own;
    if constexpr ((I::flags & kSkipOwn) != 0) own = ctx_.emit_.template get<Tag>().handle();
    cb.on_data = [this, &q, own](const Msg<Tag>& m, const fdds::SampleInfo& info) {
      if (own && info.publication_handle == *own) return;
      if constexpr (routed) {
        if (const auto lane = b_.lane_of(m); lane && *lane < lanes_.size()) {
          lanes_[*lane]->queue.push(Sample<Tag>{m, info.publication_handle});
          return;
        }
        if constexpr (!own_handler) return;  // no lane's, and the binding has no use for it
      }
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
      cb.on_deadline = [this, &q](const fdds::RequestedDeadlineMissedStatus& s) {
        if constexpr (lane_deadline) {
          for (auto& l : lanes_) l->queue.push(DeadlineMissed<Tag>{s.last_instance_handle});
        } else {
          q.push(DeadlineMissed<Tag>{s.last_instance_handle});
        }
      };
    std::get<detail::ReaderSlot<I>>(readers_).reader.emplace(
        *ctx_.participant_, std::string(Tag::topic), Tag::qos, std::move(cb), (I::flags & kAddressed) != 0);
  }

  template <class Ins>
  struct ReaderSlots;
  template <class... I>
  struct ReaderSlots<Inputs<I...>> {
    using type = std::tuple<detail::ReaderSlot<I>...>;
  };

  B& b_;
  Context<B> ctx_;  // before the readers, whose listeners push into its queue
  std::vector<std::unique_ptr<LaneLoop>> lanes_;  // fixed at configure, before the readers exist
  std::atomic<bool> lanes_stop_{false};
  std::mutex lane_failure_mutex_;
  std::exception_ptr lane_failure_;  ///< a lane's exception, rethrown on the loop's thread: the process ends
  typename ReaderSlots<typename B::Inputs>::type readers_;
  std::optional<Heartbeat> heartbeat_;
  Beat beat_;
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
