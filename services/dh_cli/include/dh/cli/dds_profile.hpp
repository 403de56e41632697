// The Fast DDS XML profile of one host of a multi-host launch file: UDPv4 pinned to the host's own
// address (nothing leaves by any other interface; the host's own processes talk over it too, without
// shared memory, as deploy/dds/loopback.xml explains), and discovery by multicast on that link or as a
// client of the deployment's discovery server.
#pragma once

#include <filesystem>
#include <string>

#include "dh/cli/launcher.hpp"

namespace dh::cli {

/// GUID prefix of `fast-discovery-server -i 0` (Fast DDS 2.x clients must name it).
inline constexpr const char* kDiscoveryServerPrefix = "44.53.00.5f.45.50.52.4f.53.49.4d.41";

/// The profile's XML text (participant profile `dh_participant`, as deploy/dds/loopback.xml).
std::string host_profile_xml(const LaunchFile& launch, const std::string& host);

/// The discovery server's own profile (`fast-discovery-server -x`): server id 0 on the server host's
/// address and port, UDPv4 only on that address. With its default transports (shared memory and every
/// interface) clients limited to UDPv4 on one address were never matched with each other.
std::string server_profile_xml(const LaunchFile& launch);

/// Writes the server's profile to `dir/<launch file stem>-discovery_server.xml` and returns that path.
std::filesystem::path write_server_profile(const LaunchFile& launch, const std::filesystem::path& dir);

/// Writes the profile to `dir/<launch file stem>-<host>.xml` and returns that path.
std::filesystem::path write_host_profile(const LaunchFile& launch, const std::string& host,
                                         const std::filesystem::path& dir);

}  // namespace dh::cli
