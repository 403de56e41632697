#include "dh/cli/dds_profile.hpp"

#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace dh::cli {

namespace {

std::string discovery_xml(const LaunchFile& launch) {
  // A dead peer is dropped after 3 s instead of the default 20 s (as deploy/dds/loopback.xml).
  const std::string leases =
      "            <leaseDuration><sec>3</sec></leaseDuration>\n"
      "            <leaseAnnouncement><sec>1</sec></leaseAnnouncement>\n";
  if (launch.discovery == Discovery::Multicast) return leases;
  const std::string& address = launch.host(launch.server_host).address;
  return "            <discoveryProtocol>CLIENT</discoveryProtocol>\n"
         "            <discoveryServersList>\n"
         "              <RemoteServer prefix=\"" + std::string(kDiscoveryServerPrefix) + "\">\n"
         "                <metatrafficUnicastLocatorList>\n"
         "                  <locator><udpv4><address>" + address + "</address><port>" +
         std::to_string(launch.server_port) + "</port></udpv4></locator>\n"
         "                </metatrafficUnicastLocatorList>\n"
         "              </RemoteServer>\n"
         "            </discoveryServersList>\n" +
         leases;
}

}  // namespace

std::string host_profile_xml(const LaunchFile& launch, const std::string& host) {
  const HostSpec& h = launch.host(host);
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!-- Made by dh for host '" + h.name + "' of " + launch.file.filename().string() +
         ": UDPv4 only on " + h.address + " (no shared memory, as deploy/dds/loopback.xml), discovery by " +
         (launch.discovery == Discovery::Multicast ? std::string("multicast on that link")
                                                   : "the discovery server on host '" + launch.server_host + "'") +
         ". -->\n"
         "<dds xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\">\n"
         "  <profiles>\n"
         "    <transport_descriptors>\n"
         "      <transport_descriptor>\n"
         "        <transport_id>dh_udp_host</transport_id>\n"
         "        <type>UDPv4</type>\n"
         "        <interfaceWhiteList><address>" + h.address + "</address></interfaceWhiteList>\n"
         "        <sendBufferSize>4194304</sendBufferSize>\n"
         "        <receiveBufferSize>4194304</receiveBufferSize>\n"
         "      </transport_descriptor>\n"
         "    </transport_descriptors>\n"
         "    <participant profile_name=\"dh_participant\">\n"
         "      <rtps>\n"
         "        <useBuiltinTransports>false</useBuiltinTransports>\n"
         "        <userTransports>\n"
         "          <transport_id>dh_udp_host</transport_id>\n"
         "        </userTransports>\n"
         "        <builtin>\n"
         "          <discovery_config>\n" +
         discovery_xml(launch) +
         "          </discovery_config>\n"
         "        </builtin>\n"
         "      </rtps>\n"
         "    </participant>\n"
         "  </profiles>\n"
         "</dds>\n";
}

std::string server_profile_xml(const LaunchFile& launch) {
  const HostSpec& h = launch.host(launch.server_host);
  const std::string port = std::to_string(launch.server_port);
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!-- Made by dh: the discovery server of " + launch.file.filename().string() + " on host '" + h.name +
         "', UDPv4 only on " + h.address + ":" + port + ". -->\n"
         "<dds xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\">\n"
         "  <profiles>\n"
         "    <transport_descriptors>\n"
         "      <transport_descriptor>\n"
         "        <transport_id>dh_udp_server</transport_id>\n"
         "        <type>UDPv4</type>\n"
         "        <interfaceWhiteList><address>" + h.address + "</address></interfaceWhiteList>\n"
         "      </transport_descriptor>\n"
         "    </transport_descriptors>\n"
         "    <participant profile_name=\"dh_discovery_server\" is_default_profile=\"true\">\n"
         "      <rtps>\n"
         "        <prefix>" + std::string(kDiscoveryServerPrefix) + "</prefix>\n"
         "        <useBuiltinTransports>false</useBuiltinTransports>\n"
         "        <userTransports><transport_id>dh_udp_server</transport_id></userTransports>\n"
         "        <builtin>\n"
         "          <discovery_config>\n"
         "            <discoveryProtocol>SERVER</discoveryProtocol>\n"
         "            <leaseDuration><sec>3</sec></leaseDuration>\n"
         "            <leaseAnnouncement><sec>1</sec></leaseAnnouncement>\n"
         "          </discovery_config>\n"
         "          <metatrafficUnicastLocatorList>\n"
         "            <locator><udpv4><address>" + h.address + "</address><port>" + port + "</port></udpv4></locator>\n"
         "          </metatrafficUnicastLocatorList>\n"
         "        </builtin>\n"
         "      </rtps>\n"
         "    </participant>\n"
         "  </profiles>\n"
         "</dds>\n";
}

namespace {
std::filesystem::path write_file(const std::filesystem::path& dir, const std::string& name, const std::string& text) {
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  // Written aside and renamed into place: another dh process of the same host (dh view beside a
  // campaign) may be loading this profile at the same moment, and must never read it half written.
  const auto part = dir / (name + ".part." + std::to_string(::getpid()));
  {
    std::ofstream out(part);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write the DDS profile " + part.string());
  }
  std::filesystem::rename(part, path);
  return path;
}
}  // namespace

std::filesystem::path write_server_profile(const LaunchFile& launch, const std::filesystem::path& dir) {
  return write_file(dir, launch.file.stem().string() + "-discovery_server.xml", server_profile_xml(launch));
}

std::filesystem::path write_host_profile(const LaunchFile& launch, const std::string& host,
                                         const std::filesystem::path& dir) {
  return write_file(dir, launch.file.stem().string() + "-" + host + ".xml", host_profile_xml(launch, host));
}

}  // namespace dh::cli
