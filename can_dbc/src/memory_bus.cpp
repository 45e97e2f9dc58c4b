#include "emadiag/can/memory_bus.hpp"

#include "emadiag/can/candump_bus.hpp"

#include <algorithm>

namespace emadiag::can {

MemoryBus::MemoryBus(MemoryBusHub& hub, std::string name) : hub_(hub), name_(std::move(name)), spec_("memory:" + name_) {
    std::lock_guard<std::mutex> lock(hub_.mutex_);
    hub_.members_.push_back(this);
}

MemoryBus::~MemoryBus() {
    std::lock_guard<std::mutex> lock(hub_.mutex_);
    hub_.members_.erase(std::remove(hub_.members_.begin(), hub_.members_.end(), this), hub_.members_.end());
}

SendStatus MemoryBus::send(const CanFrame& frame) {
    CanFrame f = frame;
    f.timestamp = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch());
    std::lock_guard<std::mutex> lock(hub_.mutex_);
    if (hub_.tap) hub_.tap(f);
    for (MemoryBus* m : hub_.members_)
        if (m != this) m->deliver(f);
    return SendStatus::Sent;
}

void MemoryBus::deliver(const CanFrame& f) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!passes_filters(f, filters_)) return;
        queue_.push_back(f);
    }
    cv_.notify_one();
}

ReceiveResult MemoryBus::receive(std::chrono::microseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return !queue_.empty(); })) return ReceiveResult{ReceiveStatus::Timeout, {}, {}};
    ReceiveResult r{ReceiveStatus::Frame, queue_.front(), {}};
    queue_.pop_front();
    return r;
}

void MemoryBus::set_filters(const std::vector<CanFilter>& filters) {
    std::lock_guard<std::mutex> lock(mutex_);
    filters_ = filters;
}

}  // namespace emadiag::can
