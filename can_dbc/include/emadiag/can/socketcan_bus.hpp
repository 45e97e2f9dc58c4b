#pragma once
// Linux SocketCAN raw socket: CAN FD capable, acceptance filters, kernel receive timestamps
// (SO_TIMESTAMPNS), a large receive buffer, and error frames with bus-off detection.
#include "emadiag/can/can_bus.hpp"

#include <cstddef>

struct canfd_frame;
struct msghdr;

namespace emadiag::can {

struct SocketCanOptions {
    std::size_t receive_buffer_bytes = std::size_t{8} << 20;  ///< SO_RCVBUF(FORCE); the kernel may cap it
    bool fd_frames = true;                                    ///< CAN_RAW_FD_FRAMES
    bool error_frames = true;                                 ///< CAN_RAW_ERR_FILTER for every error class
    bool receive_own = false;                                 ///< CAN_RAW_RECV_OWN_MSGS
    std::chrono::milliseconds send_timeout{200};              ///< wait for a full tx queue to drain
};

class SocketCanBus final : public CanBus {
public:
    /// Opens and binds a raw socket on `iface`; throws CanError naming the interface and errno text.
    explicit SocketCanBus(const std::string& iface, SocketCanOptions options = {});
    ~SocketCanBus() override;

    SendStatus send(const CanFrame& frame) override;
    ReceiveResult receive(std::chrono::microseconds timeout) override;
    /// sendmmsg: one system call for up to kMaxBatch frames.
    BatchSendResult send_batch(const std::vector<CanFrame>& frames) override;
    /// recvmmsg: one system call for everything queued (up to kMaxBatch), ppoll only when empty.
    std::size_t receive_batch(std::vector<ReceiveResult>& out, std::size_t max_results, std::chrono::microseconds timeout) override;
    void set_filters(const std::vector<CanFilter>& filters) override;
    [[nodiscard]] const std::string& spec() const override { return spec_; }
    [[nodiscard]] const std::string& interface_name() const override { return iface_; }
    /// Receive buffer size the kernel granted, in bytes.
    [[nodiscard]] std::size_t receive_buffer_bytes() const { return rcvbuf_bytes_; }

    /// Frames moved by one sendmmsg / recvmmsg call.
    static constexpr std::size_t kMaxBatch = 64;

private:
    std::size_t to_kernel(const CanFrame& f, canfd_frame& cf) const;
    ReceiveResult from_kernel(const canfd_frame& cf, std::size_t bytes, const msghdr& msg) const;
    bool wait_readable(std::chrono::microseconds timeout) const;
    int fd_ = -1;
    std::string iface_;
    std::string spec_;
    SocketCanOptions options_;
    std::size_t rcvbuf_bytes_ = 0;
};

}  // namespace emadiag::can
