#pragma once
// Test support: the simulated EMA node serving its own in-process MemoryBus in a thread
// (the node tests and the recorder tests both drive it this way).
#include "emadiag/can/memory_bus.hpp"
#include "emadiag/node/ema_node.hpp"

#include <atomic>
#include <thread>
#include <utility>

namespace emadiag::test {

class NodeRunner {
public:
    NodeRunner(can::MemoryBusHub& hub, node::EmaNodeConfig cfg) : bus_(hub, "ema"), node_(bus_, std::move(cfg)) {
        thread_ = std::thread([this] { node_.run(stop_); });
    }
    NodeRunner(const NodeRunner&) = delete;
    NodeRunner& operator=(const NodeRunner&) = delete;
    ~NodeRunner() { stop(); }
    void stop() {
        stop_ = true;
        if (thread_.joinable()) thread_.join();
    }
    const node::EmaNodeStats& stats() const { return node_.stats(); }

private:
    can::MemoryBus bus_;
    node::EmaNode node_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

}  // namespace emadiag::test
