// Every DDS topic name in one place (ROS 2 naming: rt/dh/...). QoS per topic: dds.hpp, qos_for().
#pragma once

namespace dh::topics {

inline constexpr const char* kAnnounce = "rt/dh/capability/announce";
inline constexpr const char* kCommand = "rt/dh/command";
inline constexpr const char* kCommandStatus = "rt/dh/command/status";
inline constexpr const char* kLease = "rt/dh/lease";
inline constexpr const char* kAction = "rt/dh/action";
inline constexpr const char* kObservation = "rt/dh/observation";
inline constexpr const char* kVerdict = "rt/dh/verdict";
inline constexpr const char* kSeamEvent = "rt/dh/seam/event";
inline constexpr const char* kPlanRequest = "rt/dh/planner/request";
inline constexpr const char* kAdvice = "rt/dh/planner/advice";
inline constexpr const char* kEpisodeRequest = "rt/dh/episode/request";
inline constexpr const char* kEpisodeResult = "rt/dh/episode/result";
inline constexpr const char* kChannelStatus = "rt/dh/sim/channel";
inline constexpr const char* kCamera = "rt/dh/camera";
inline constexpr const char* kSceneEstimate = "rt/dh/perception/scene";
inline constexpr const char* kEvidence = "rt/dh/evidence";                   ///< EpisodeLive, for live views
inline constexpr const char* kCampaignProgress = "rt/dh/campaign/progress";  ///< CampaignProgress

}  // namespace dh::topics

// RGB-D frames (idl/camera.idl RgbdFrame) and the requests that ask for one (RgbdRequest).
namespace dh::topics {
inline constexpr const char* kRgbd = "rt/dh/camera/rgbd";
inline constexpr const char* kRgbdRequest = "rt/dh/camera/rgbd/request";
}  // namespace dh::topics
