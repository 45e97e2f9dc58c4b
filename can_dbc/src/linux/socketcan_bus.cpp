// Linux SocketCAN raw socket (see socketcan_bus.hpp).
#include "emadiag/can/socketcan_bus.hpp"

#include "emadiag/can/can_error.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

namespace emadiag::can {
namespace {

std::string errno_text(int e) { return std::string(std::strerror(e)); }

constexpr std::chrono::microseconds kSendRetryPause{200};

std::string describe_error_frame(const can_frame& cf) {
    std::string s;
    const canid_t c = cf.can_id & CAN_ERR_MASK;
    auto add = [&](canid_t bit, const char* name) {
        if (c & bit) s += (s.empty() ? "" : ", ") + std::string(name);
    };
    add(CAN_ERR_TX_TIMEOUT, "tx timeout");
    add(CAN_ERR_LOSTARB, "lost arbitration");
    add(CAN_ERR_CRTL, "controller problem");
    add(CAN_ERR_PROT, "protocol violation");
    add(CAN_ERR_TRX, "transceiver status");
    add(CAN_ERR_ACK, "no ack");
    add(CAN_ERR_BUSOFF, "bus-off");
    add(CAN_ERR_BUSERROR, "bus error");
    add(CAN_ERR_RESTARTED, "controller restarted");
    if (c & CAN_ERR_CRTL) {
        if (cf.data[1] & CAN_ERR_CRTL_RX_OVERFLOW) s += " (rx overflow)";
        if (cf.data[1] & CAN_ERR_CRTL_TX_OVERFLOW) s += " (tx overflow)";
        if (cf.data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) s += " (error passive)";
    }
    return s.empty() ? "unspecified error" : s;
}

}  // namespace

SocketCanBus::SocketCanBus(const std::string& iface, SocketCanOptions options)
    : iface_(iface), spec_("socketcan:" + iface), options_(options) {
    if (iface.empty() || iface.size() >= IFNAMSIZ) throw CanError("socketcan: invalid interface name '" + iface + "'");
    fd_ = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd_ < 0) {
        const int e = errno;
        throw CanError("socketcan:" + iface + ": cannot open a CAN_RAW socket: " + errno_text(e) +
                       (e == EAFNOSUPPORT ? " (this kernel has no CAN support; load can and can-raw)" : ""));
    }
    auto fail = [&](const std::string& what) {
        const int e = errno;
        ::close(fd_);
        fd_ = -1;
        throw CanError("socketcan:" + iface + ": " + what + ": " + errno_text(e));
    };
    if (options_.fd_frames) {
        const int on = 1;
        if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) < 0) fail("cannot enable CAN FD frames");
    }
    if (options_.error_frames) {
        const can_err_mask_t mask = CAN_ERR_MASK;
        if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) < 0) fail("cannot enable error frames");
    }
    if (options_.receive_own) {
        const int on = 1;
        if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &on, sizeof on) < 0) fail("cannot enable own messages");
    }
    const int on = 1;
    if (::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) < 0) fail("cannot enable kernel timestamps");
    int rcvbuf = static_cast<int>(options_.receive_buffer_bytes);
    // SO_RCVBUFFORCE passes rmem_max with CAP_NET_ADMIN; otherwise take what SO_RCVBUF grants.
    if (::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof rcvbuf) < 0)
        (void)::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    int granted = 0;
    socklen_t len = sizeof granted;
    if (::getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &granted, &len) == 0) rcvbuf_bytes_ = static_cast<std::size_t>(granted);

    ifreq ifr{};
    std::strncpy(ifr.ifr_name, iface.c_str(), IFNAMSIZ - 1);
    if (::ioctl(fd_, SIOCGIFINDEX, &ifr) < 0) fail("no such CAN interface");
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) fail("cannot bind");
}

SocketCanBus::~SocketCanBus() {
    if (fd_ >= 0) ::close(fd_);
}

SendStatus SocketCanBus::send(const CanFrame& f) {
    canfd_frame cf{};
    cf.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
    if (f.rtr) cf.can_id |= CAN_RTR_FLAG;
    const std::size_t max = f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN;
    if (f.len > max || (f.fd && !is_valid_fd_len(f.len)))
        throw CanError(spec_ + ": frame " + format_id(f.id, f.extended) + " has length " + std::to_string(f.len) +
                       (f.fd ? ", not a CAN FD length" : ", above 8 for classic CAN"));
    cf.len = f.len;
    if (f.fd) cf.flags = static_cast<__u8>((f.brs ? CANFD_BRS : 0) | (f.esi ? CANFD_ESI : 0));
    std::memcpy(cf.data, f.data.data(), f.len);
    const std::size_t mtu = f.fd ? CANFD_MTU : CAN_MTU;
    const auto deadline = std::chrono::steady_clock::now() + options_.send_timeout;
    for (;;) {
        const ssize_t n = ::write(fd_, &cf, mtu);
        if (n == static_cast<ssize_t>(mtu)) return SendStatus::Sent;
        const int e = errno;
        if (n < 0 && (e == ENETDOWN || e == ENXIO || e == ENODEV)) return SendStatus::BusOff;
        if (n < 0 && e == EINVAL && f.fd) throw CanError(spec_ + ": the interface does not accept CAN FD frames");
        if (n < 0 && e != ENOBUFS && e != EAGAIN && e != EINTR)
            throw CanError(spec_ + ": write of frame " + format_id(f.id, f.extended) + " failed: " + errno_text(e));
        if (std::chrono::steady_clock::now() >= deadline) return SendStatus::QueueFull;
        std::this_thread::sleep_for(kSendRetryPause);
    }
}

ReceiveResult SocketCanBus::receive(std::chrono::microseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
        const long long left_us = left.count() < 0 ? 0 : left.count();
        timespec ts{static_cast<time_t>(left_us / 1000000), static_cast<long>((left_us % 1000000) * 1000)};
        pollfd p{fd_, POLLIN, 0};
        const int r = ::ppoll(&p, 1, &ts, nullptr);
        if (r < 0) {
            if (errno == EINTR) return ReceiveResult{ReceiveStatus::Timeout, {}, "interrupted"};
            throw CanError(spec_ + ": poll failed: " + errno_text(errno));
        }
        if (r == 0) return ReceiveResult{ReceiveStatus::Timeout, {}, {}};
        canfd_frame cf{};
        iovec iov{&cf, sizeof cf};
        alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + 64];
        msghdr msg{};
        msg.msg_iov = &iov;
        msg.msg_iovlen = 1;
        msg.msg_control = control;
        msg.msg_controllen = sizeof control;
        const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EAGAIN || errno == EINTR) continue;
            if (errno == ENETDOWN) return ReceiveResult{ReceiveStatus::BusOff, {}, spec_ + ": interface down"};
            throw CanError(spec_ + ": receive failed: " + errno_text(errno));
        }
        CanFrame f;
        for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
            if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
                timespec t;
                std::memcpy(&t, CMSG_DATA(c), sizeof t);
                f.timestamp = std::chrono::seconds(t.tv_sec) + std::chrono::nanoseconds(t.tv_nsec);
            }
        }
        if (n == CANFD_MTU) {
            f.fd = true;
            f.brs = (cf.flags & CANFD_BRS) != 0;
            f.esi = (cf.flags & CANFD_ESI) != 0;
        } else if (n != CAN_MTU) {
            throw CanError(spec_ + ": received " + std::to_string(n) + " bytes, neither CAN_MTU nor CANFD_MTU");
        }
        f.len = static_cast<std::uint8_t>(std::min<std::size_t>(cf.len, f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN));
        std::memcpy(f.data.data(), cf.data, f.len);
        if (cf.can_id & CAN_ERR_FLAG) {
            f.error = true;
            f.id = cf.can_id & CAN_ERR_MASK;
            can_frame classic{};
            classic.can_id = cf.can_id;
            std::memcpy(classic.data, cf.data, CAN_MAX_DLEN);
            const std::string what = describe_error_frame(classic);
            if (cf.can_id & CAN_ERR_BUSOFF) return ReceiveResult{ReceiveStatus::BusOff, f, spec_ + ": " + what};
            return ReceiveResult{ReceiveStatus::ErrorFrame, f, spec_ + ": " + what};
        }
        f.extended = (cf.can_id & CAN_EFF_FLAG) != 0;
        f.rtr = (cf.can_id & CAN_RTR_FLAG) != 0;
        f.id = f.extended ? (cf.can_id & CAN_EFF_MASK) : (cf.can_id & CAN_SFF_MASK);
        return ReceiveResult{ReceiveStatus::Frame, f, {}};
    }
}

void SocketCanBus::set_filters(const std::vector<CanFilter>& filters) {
    std::vector<can_filter> k;
    for (const auto& flt : filters) {
        can_filter c{};
        c.can_id = flt.extended ? ((flt.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (flt.id & CAN_SFF_MASK);
        c.can_mask = (flt.extended ? (flt.mask & CAN_EFF_MASK) : (flt.mask & CAN_SFF_MASK)) | CAN_EFF_FLAG | CAN_RTR_FLAG;
        k.push_back(c);
    }
    const void* p = k.empty() ? nullptr : k.data();
    if (k.empty()) {  // accept everything
        can_filter all{0, 0};
        if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, &all, sizeof all) < 0)
            throw CanError(spec_ + ": cannot set filters: " + errno_text(errno));
        return;
    }
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, p, static_cast<socklen_t>(k.size() * sizeof(can_filter))) < 0)
        throw CanError(spec_ + ": cannot set filters: " + errno_text(errno));
}

}  // namespace emadiag::can
