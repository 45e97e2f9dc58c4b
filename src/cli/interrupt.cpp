#include "cli/interrupt.hpp"

#include <csignal>

namespace {
std::atomic<bool> g_interrupt{false};
extern "C" void emadiag_on_interrupt(int) { g_interrupt.store(true); }
}  // namespace

namespace emadiag::cli {

const std::atomic<bool>& install_interrupt_handler() {
    struct sigaction sa {};
    sa.sa_handler = emadiag_on_interrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    return g_interrupt;
}

}  // namespace emadiag::cli
