// The managed lifecycle's transitions: the allowed ones run their callback, a failing callback leaves the
// state and says why, and a transition the state does not allow is refused by name.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "dh/common/lifecycle.hpp"

using namespace dh;
using T = LifecycleTransition;
using S = LifecycleState;

namespace {

struct Recorder {
  std::vector<std::string> calls;
  bool fail_activate = false;
  LifecycleCallbacks callbacks() {
    return {[this] { calls.push_back("configure"); },
            [this] {
              calls.push_back("activate");
              if (fail_activate) throw std::runtime_error("no DDS participant: domain 300 is out of range");
            },
            [this] { calls.push_back("drain"); }, [this] { calls.push_back("deactivate"); },
            [this] { calls.push_back("shutdown"); }};
  }
};

}  // namespace

TEST(Lifecycle, ARunGoesThroughEveryStateInOrder) {
  Recorder r;
  Lifecycle life(r.callbacks());
  EXPECT_EQ(life.state(), S::Unconfigured);
  for (auto [t, want] : std::vector<std::pair<T, S>>{{T::Configure, S::Inactive},
                                                      {T::Activate, S::Active},
                                                      {T::Drain, S::Draining},
                                                      {T::Deactivate, S::Inactive},
                                                      {T::Activate, S::Active},
                                                      {T::Deactivate, S::Inactive},
                                                      {T::Shutdown, S::Finalized}}) {
    const TransitionResult res = life.trigger(t);
    EXPECT_TRUE(res.ok) << to_string(t) << ": " << res.reason;
    EXPECT_EQ(res.to, want) << to_string(t);
    EXPECT_EQ(life.state(), want);
  }
  EXPECT_EQ(r.calls, (std::vector<std::string>{"configure", "activate", "drain", "deactivate", "activate",
                                                "deactivate", "shutdown"}));
}

TEST(Lifecycle, AFailingCallbackLeavesTheStateAndGivesItsReason) {
  Recorder r;
  r.fail_activate = true;
  Lifecycle life(r.callbacks());
  ASSERT_TRUE(life.trigger(T::Configure).ok);
  const TransitionResult res = life.trigger(T::Activate);
  EXPECT_FALSE(res.ok);
  EXPECT_EQ(res.from, S::Inactive);
  EXPECT_EQ(res.to, S::Inactive);
  EXPECT_EQ(res.reason, "no DDS participant: domain 300 is out of range");
  EXPECT_EQ(life.state(), S::Inactive);
  EXPECT_TRUE(life.trigger(T::Shutdown).ok) << "what was configured is still shut down";
}

TEST(Lifecycle, ATransitionTheStateDoesNotAllowIsRefusedWithoutItsCallback) {
  Recorder r;
  Lifecycle life(r.callbacks());
  for (T t : {T::Activate, T::Drain, T::Deactivate}) {
    const TransitionResult res = life.trigger(t);
    EXPECT_FALSE(res.ok) << to_string(t);
    EXPECT_EQ(res.reason, std::string("cannot ") + to_string(t) + " from unconfigured");
  }
  EXPECT_TRUE(r.calls.empty());
  ASSERT_TRUE(life.trigger(T::Configure).ok);
  EXPECT_EQ(life.trigger(T::Configure).reason, "cannot configure from inactive");
  EXPECT_EQ(life.trigger(T::Drain).reason, "cannot drain from inactive") << "only an active service drains";
  ASSERT_TRUE(life.trigger(T::Shutdown).ok);
  EXPECT_EQ(life.trigger(T::Shutdown).reason, "cannot shutdown from finalized");
  EXPECT_EQ(r.calls, (std::vector<std::string>{"configure", "shutdown"}));
}

TEST(Lifecycle, UnsetCallbacksHaveNothingToDo) {
  Lifecycle life({});
  EXPECT_TRUE(life.trigger(T::Configure).ok);
  EXPECT_TRUE(life.trigger(T::Activate).ok);
  EXPECT_TRUE(life.trigger(T::Shutdown).ok);
  EXPECT_EQ(life.state(), S::Finalized);
}
