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
#include <algorithm>
#include <array>
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

std::size_t SocketCanBus::to_kernel(const CanFrame& f, canfd_frame& cf) const {
    cf = canfd_frame{};
    cf.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
    if (f.rtr) cf.can_id |= CAN_RTR_FLAG;
    const std::size_t max = f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN;
    if (f.len > max || (f.fd && !is_valid_fd_len(f.len)))
        throw CanError(spec_ + ": frame " + format_id(f.id, f.extended) + " has length " + std::to_string(f.len) +
                       (f.fd ? ", not a CAN FD length" : ", above 8 for classic CAN"));
    cf.len = f.len;
    if (f.fd) cf.flags = static_cast<__u8>((f.brs ? CANFD_BRS : 0) | (f.esi ? CANFD_ESI : 0));
    std::memcpy(cf.data, f.data.data(), f.len);
    return f.fd ? CANFD_MTU : CAN_MTU;
}

SendStatus SocketCanBus::send(const CanFrame& f) {
    canfd_frame cf;
    const std::size_t mtu = to_kernel(f, cf);
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

BatchSendResult SocketCanBus::send_batch(const std::vector<CanFrame>& frames) {
    BatchSendResult result;
    std::size_t done = 0;
    while (done < frames.size()) {
        const std::size_t n = std::min(frames.size() - done, kMaxBatch);
        std::array<canfd_frame, kMaxBatch> cf;
        std::array<iovec, kMaxBatch> iov;
        std::array<mmsghdr, kMaxBatch> msgs{};
        for (std::size_t i = 0; i < n; ++i) {
            iov[i].iov_base = &cf[i];
            iov[i].iov_len = to_kernel(frames[done + i], cf[i]);
            msgs[i].msg_hdr.msg_iov = &iov[i];
            msgs[i].msg_hdr.msg_iovlen = 1;
        }
        const int sent = ::sendmmsg(fd_, msgs.data(), static_cast<unsigned>(n), 0);
        if (sent > 0) {
            done += static_cast<std::size_t>(sent);
            result.sent = done;
            continue;
        }
        // Nothing went out: the single-frame path waits for a full queue and classifies the error.
        result.status = send(frames[done]);
        if (result.status != SendStatus::Sent) return result;
        result.sent = ++done;
    }
    return result;
}

ReceiveResult SocketCanBus::from_kernel(const canfd_frame& cf, std::size_t bytes, const msghdr& msg) const {
    CanFrame f;
    for (const cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(const_cast<msghdr*>(&msg), const_cast<cmsghdr*>(c))) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
            timespec t;
            std::memcpy(&t, CMSG_DATA(c), sizeof t);
            f.timestamp = std::chrono::seconds(t.tv_sec) + std::chrono::nanoseconds(t.tv_nsec);
        }
    }
    if (bytes == CANFD_MTU) {
        f.fd = true;
        f.brs = (cf.flags & CANFD_BRS) != 0;
        f.esi = (cf.flags & CANFD_ESI) != 0;
    } else if (bytes != CAN_MTU) {
        throw CanError(spec_ + ": received " + std::to_string(bytes) + " bytes, neither CAN_MTU nor CANFD_MTU");
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

bool SocketCanBus::wait_readable(std::chrono::microseconds timeout) const {
    const long long us = timeout.count() < 0 ? 0 : timeout.count();
    timespec ts{static_cast<time_t>(us / 1000000), static_cast<long>((us % 1000000) * 1000)};
    pollfd p{fd_, POLLIN, 0};
    const int r = ::ppoll(&p, 1, &ts, nullptr);
    if (r < 0) {
        if (errno == EINTR) return false;
        throw CanError(spec_ + ": poll failed: " + errno_text(errno));
    }
    return r > 0;
}

ReceiveResult SocketCanBus::receive(std::chrono::microseconds timeout) {
    std::vector<ReceiveResult> one;
    if (receive_batch(one, 1, timeout) == 0) return ReceiveResult{ReceiveStatus::Timeout, {}, {}};
    return std::move(one.front());
}

std::size_t SocketCanBus::receive_batch(std::vector<ReceiveResult>& out, std::size_t max_results, std::chrono::microseconds timeout) {
    if (max_results == 0) return 0;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    struct Slot {
        canfd_frame cf;
        iovec iov;
        alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + 64];
    };
    const std::size_t n = std::min(max_results, kMaxBatch);
    std::array<Slot, kMaxBatch> slots;
    std::array<mmsghdr, kMaxBatch> msgs{};
    bool waited = false;
    for (;;) {
        for (std::size_t i = 0; i < n; ++i) {
            slots[i].iov = iovec{&slots[i].cf, sizeof slots[i].cf};
            msgs[i] = mmsghdr{};
            msgs[i].msg_hdr.msg_iov = &slots[i].iov;
            msgs[i].msg_hdr.msg_iovlen = 1;
            msgs[i].msg_hdr.msg_control = slots[i].control;
            msgs[i].msg_hdr.msg_controllen = sizeof slots[i].control;
        }
        // Try first without waiting: under load frames are usually queued, and one system call
        // then takes a whole batch.
        const int got = ::recvmmsg(fd_, msgs.data(), static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
        if (got > 0) {
            std::size_t appended = 0;
            for (std::size_t i = 0; i < static_cast<std::size_t>(got); ++i) {
                out.push_back(from_kernel(slots[i].cf, msgs[i].msg_len, msgs[i].msg_hdr));
                ++appended;
            }
            return appended;
        }
        const int e = errno;
        if (got < 0 && e == ENETDOWN) {
            out.push_back(ReceiveResult{ReceiveStatus::BusOff, {}, spec_ + ": interface down"});
            return 1;
        }
        if (got < 0 && e != EAGAIN && e != EWOULDBLOCK && e != EINTR) throw CanError(spec_ + ": receive failed: " + errno_text(e));
        const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
        if (waited && left.count() <= 0) return 0;
        if (!wait_readable(std::max(left, std::chrono::microseconds{0}))) return 0;
        waited = true;
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
