#pragma once
// An in-process bus for tests and tools: every MemoryBus attached to one MemoryBusHub receives the
// frames the others send (not its own), in order, with a steady timestamp. Thread-safe.
#include "emadiag/can/can_bus.hpp"

#include <condition_variable>
#include <functional>
#include <deque>
#include <mutex>

namespace emadiag::can {

class MemoryBus;

class MemoryBusHub {
public:
    /// Optional: a transmit hook that sees every frame (e.g. to keep a log).
    std::function<void(const CanFrame&)> tap;

private:
    friend class MemoryBus;
    std::mutex mutex_;
    std::vector<MemoryBus*> members_;
};

class MemoryBus final : public CanBus {
public:
    explicit MemoryBus(MemoryBusHub& hub, std::string name = "mem0");
    ~MemoryBus() override;

    SendStatus send(const CanFrame& frame) override;
    ReceiveResult receive(std::chrono::microseconds timeout) override;
    void set_filters(const std::vector<CanFilter>& filters) override;
    [[nodiscard]] const std::string& spec() const override { return spec_; }
    [[nodiscard]] const std::string& interface_name() const override { return name_; }

private:
    void deliver(const CanFrame& f);
    MemoryBusHub& hub_;
    std::string name_;
    std::string spec_;
    std::mutex mutex_;
    std::condition_variable cv_;
    std::deque<CanFrame> queue_;
    std::vector<CanFilter> filters_;
};

}  // namespace emadiag::can
