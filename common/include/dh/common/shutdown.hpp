// SIGINT/SIGTERM handling: nodes poll shutdown_requested() and delete their DDS entities on the way
// out, so no shared-memory segments are left behind.
#pragma once

namespace dh {

void install_shutdown_handlers();
bool shutdown_requested();
void request_shutdown();

}  // namespace dh
