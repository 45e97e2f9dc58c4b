// The signal codec: fast windowed extraction and a bit-by-bit reference.
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/dbc.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace emadiag::can {
namespace {

__extension__ typedef unsigned __int128 Wide;

constexpr std::uint32_t kMaxSignalBits = 64;

std::uint64_t mask_of(std::uint32_t length) {
    return length >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << length) - 1;
}

int get_bit(const std::uint8_t* data, std::uint32_t pos) { return (data[pos / 8] >> (pos % 8)) & 1; }
void set_bit(std::uint8_t* data, std::uint32_t pos, int v) {
    if (v) data[pos / 8] = static_cast<std::uint8_t>(data[pos / 8] | (1u << (pos % 8)));
    else data[pos / 8] = static_cast<std::uint8_t>(data[pos / 8] & ~(1u << (pos % 8)));
}

std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

}  // namespace

std::string format_id(std::uint32_t id, bool extended) {
    char buf[16];
    std::snprintf(buf, sizeof buf, extended ? "0x%08X" : "0x%03X", id);
    return buf;
}

std::optional<std::string> Signal::compute_layout(std::size_t message_len) {
    if (length == 0 || length > kMaxSignalBits) {
        return "signal '" + name + "' has length " + std::to_string(length) + " bits; allowed 1 to 64";
    }
    SignalLayout l;
    l.mask = mask_of(length);
    std::uint64_t last_bit_pos = 0;  // linear position of the last bit touched, for the size check
    if (byte_order == ByteOrder::LittleEndian) {
        l.first_byte = start_bit / 8;
        const std::uint64_t last = std::uint64_t{start_bit} + length - 1;
        l.n_bytes = static_cast<std::uint32_t>(last / 8 - l.first_byte + 1);
        l.shift = start_bit % 8;
        last_bit_pos = last;
    } else {
        const std::uint64_t p_msb = std::uint64_t{start_bit / 8} * 8 + 7 - start_bit % 8;
        const std::uint64_t p_lsb = p_msb + length - 1;
        l.first_byte = start_bit / 8;
        l.n_bytes = static_cast<std::uint32_t>(p_lsb / 8 - l.first_byte + 1);
        l.shift = static_cast<std::uint32_t>(7 - p_lsb % 8);
        last_bit_pos = p_lsb;
    }
    l.required_len = static_cast<std::uint32_t>(last_bit_pos / 8 + 1);
    if (l.required_len > message_len) {
        return "signal '" + name + "' (start bit " + std::to_string(start_bit) + ", length " + std::to_string(length) +
               (byte_order == ByteOrder::LittleEndian ? ", little-endian" : ", big-endian") + ") needs " +
               std::to_string(l.required_len) + " bytes but the message has " + std::to_string(message_len);
    }
    layout = l;
    return std::nullopt;
}

std::uint64_t Signal::extract_raw_wide(const std::uint8_t* data) const {
    const SignalLayout& l = layout;
    const std::uint8_t* p = data + l.first_byte;
    Wide v = 0;
    if (byte_order == ByteOrder::LittleEndian) {
        for (std::uint32_t i = 0; i < l.n_bytes; ++i) v |= Wide{p[i]} << (8 * i);
    } else {
        for (std::uint32_t i = 0; i < l.n_bytes; ++i) v = (v << 8) | p[i];
    }
    return static_cast<std::uint64_t>(v >> l.shift) & l.mask;
}

void Signal::insert_raw(std::uint64_t raw, std::uint8_t* data) const {
    const SignalLayout& l = layout;
    const Wide v = Wide{raw & l.mask} << l.shift;
    const Wide m = Wide{l.mask} << l.shift;
    std::uint8_t* p = data + l.first_byte;
    for (std::uint32_t i = 0; i < l.n_bytes; ++i) {
        const std::uint32_t sh = byte_order == ByteOrder::LittleEndian ? 8 * i : 8 * (l.n_bytes - 1 - i);
        const auto vb = static_cast<std::uint8_t>(v >> sh);
        const auto mb = static_cast<std::uint8_t>(m >> sh);
        p[i] = static_cast<std::uint8_t>((p[i] & ~mb) | (vb & mb));
    }
}

std::uint64_t Signal::extract_raw_reference(const std::uint8_t* data, std::size_t len) const {
    std::uint64_t raw = 0;
    if (byte_order == ByteOrder::LittleEndian) {
        for (std::uint32_t i = 0; i < length; ++i) {
            const std::uint32_t pos = start_bit + i;
            if (pos / 8 >= len) throw CanError("signal '" + name + "': bit " + std::to_string(pos) + " beyond " + std::to_string(len) + " bytes");
            raw |= std::uint64_t(get_bit(data, pos)) << i;
        }
    } else {
        std::uint32_t pos = start_bit;
        for (std::uint32_t i = 0; i < length; ++i) {
            if (pos / 8 >= len) throw CanError("signal '" + name + "': bit " + std::to_string(pos) + " beyond " + std::to_string(len) + " bytes");
            raw = (raw << 1) | std::uint64_t(get_bit(data, pos));
            pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
        }
    }
    return raw;
}

void Signal::insert_raw_reference(std::uint64_t raw, std::uint8_t* data, std::size_t len) const {
    if (byte_order == ByteOrder::LittleEndian) {
        for (std::uint32_t i = 0; i < length; ++i) {
            const std::uint32_t pos = start_bit + i;
            if (pos / 8 >= len) throw CanError("signal '" + name + "': bit " + std::to_string(pos) + " beyond " + std::to_string(len) + " bytes");
            set_bit(data, pos, static_cast<int>((raw >> i) & 1));
        }
    } else {
        std::uint32_t pos = start_bit;
        for (std::uint32_t i = 0; i < length; ++i) {
            if (pos / 8 >= len) throw CanError("signal '" + name + "': bit " + std::to_string(pos) + " beyond " + std::to_string(len) + " bytes");
            set_bit(data, pos, static_cast<int>((raw >> (length - 1 - i)) & 1));
            pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
        }
    }
}

double Signal::float_from_raw32(std::uint64_t raw) {
    const auto bits = static_cast<std::uint32_t>(raw);
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

double Signal::double_from_raw64(std::uint64_t raw) {
    double d;
    std::memcpy(&d, &raw, sizeof d);
    return d;
}

double Signal::raw_min() const {
    if (!is_signed) return 0.0;
    return -std::ldexp(1.0, static_cast<int>(length) - 1);
}

double Signal::raw_max() const {
    if (!is_signed) return std::ldexp(1.0, static_cast<int>(length)) - 1.0;
    return std::ldexp(1.0, static_cast<int>(length) - 1) - 1.0;
}

std::uint64_t Signal::physical_to_raw(double physical) const {
    if (!std::isfinite(physical)) throw CanError("signal '" + name + "': value " + num(physical) + " is not finite");
    const double scaled = (physical - offset) / factor;
    if (value_type == ValueType::Float32) {
        const auto f = static_cast<float>(scaled);
        if (!std::isfinite(f)) throw CanError("signal '" + name + "': value " + num(physical) + " overflows float32");
        std::uint32_t bits;
        std::memcpy(&bits, &f, sizeof bits);
        return bits;
    }
    if (value_type == ValueType::Float64) {
        std::uint64_t bits;
        std::memcpy(&bits, &scaled, sizeof bits);
        return bits;
    }
    const double r = std::nearbyint(scaled);
    if (r < raw_min() || r > raw_max()) {
        throw CanError("signal '" + name + "': value " + num(physical) + " needs raw " + num(r) + ", outside the " +
                       std::to_string(length) + "-bit " + (is_signed ? "signed" : "unsigned") + " range [" +
                       num(raw_min() * factor + offset) + ", " + num(raw_max() * factor + offset) + "]");
    }
    if (is_signed) return static_cast<std::uint64_t>(static_cast<std::int64_t>(r)) & layout.mask;
    return static_cast<std::uint64_t>(r) & layout.mask;
}

}  // namespace emadiag::can
