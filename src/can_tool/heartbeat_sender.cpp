#include "can_tool/heartbeat_sender.hpp"

#ifdef __linux__
#include <pthread.h>
#include <sched.h>
#endif

namespace emadiag::can_tool {
namespace {

/// SCHED_FIFO for the calling thread; false (and nothing changed) where the OS refuses it.
bool try_realtime() {
#ifdef __linux__
    sched_param sp{};
    sp.sched_priority = kHeartbeatRealtimePriority;
    return ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &sp) == 0;
#else
    return false;
#endif
}

}  // namespace

HeartbeatSender::HeartbeatSender(can::CanBus& bus, std::chrono::milliseconds period) : bus_(bus), period_(period) {}

HeartbeatSender::~HeartbeatSender() { stop(); }

void HeartbeatSender::start() {
    if (thread_.joinable()) return;
    {
        std::lock_guard lock(mutex_);
        stop_ = false;
    }
    thread_ = std::thread([this] { loop(); });
}

void HeartbeatSender::stop() {
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
}

void HeartbeatSender::take_sent(std::vector<can::CanFrame>& out) {
    std::lock_guard lock(mutex_);
    out.insert(out.end(), sent_.begin(), sent_.end());
    sent_.clear();
}

std::optional<std::string> HeartbeatSender::failure() const {
    std::lock_guard lock(mutex_);
    return failure_;
}

HeartbeatStats HeartbeatSender::stats() const {
    std::lock_guard lock(mutex_);
    return stats_;
}

void HeartbeatSender::loop() {
    using Clock = std::chrono::steady_clock;
    const bool realtime = try_realtime();
    {
        std::lock_guard lock(mutex_);
        stats_.realtime = realtime;
    }
    std::uint8_t counter = 0;
    auto next = Clock::now();
    std::optional<Clock::time_point> last_sent;
    std::unique_lock lock(mutex_);
    for (;;) {
        if (wake_.wait_until(lock, next, [this] { return stop_; })) return;
        lock.unlock();
        can::CanFrame f = icd_.encode_heartbeat(counter++);
        f.timestamp = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch());
        const can::SendStatus status = bus_.send(f);
        const auto now = Clock::now();
        lock.lock();
        if (status == can::SendStatus::Sent) {
            ++stats_.sent;
            if (last_sent)
                stats_.max_gap = std::max(stats_.max_gap, std::chrono::duration_cast<std::chrono::microseconds>(now - *last_sent));
            last_sent = now;
            sent_.push_back(f);
        } else {
            ++stats_.send_failures;
            if (!failure_) failure_ = can::to_string(status);
        }
        // Absolute deadlines keep 50 Hz on average; after a stall the next beat goes out at once
        // and the schedule restarts from it (no burst of make-up beats).
        next += period_;
        if (next < now) next = now;
    }
}

}  // namespace emadiag::can_tool
