// The signal codec: hand-computed golden values, sign extension, floats, and a property test of
// the fast codec against the bit-by-bit reference (seed and count overridable, printed).
#include "emadiag/can/can_error.hpp"
#include "emadiag/can/crc8.hpp"
#include "emadiag/can/dbc.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <random>

using namespace emadiag::can;
using ::testing::HasSubstr;

namespace {

Signal make(std::uint32_t start, std::uint32_t len, ByteOrder order, bool is_signed = false, std::size_t msg_len = 8) {
    Signal s;
    s.name = "S";
    s.start_bit = start;
    s.length = len;
    s.byte_order = order;
    s.is_signed = is_signed;
    if (auto e = s.compute_layout(msg_len)) throw CanError(*e);
    return s;
}

std::uint64_t env_u64(const char* name, std::uint64_t fallback) {
    const char* v = std::getenv(name);
    return v ? std::strtoull(v, nullptr, 10) : fallback;
}

::testing::AssertionResult same_codec(const Signal& s, const std::vector<std::uint8_t>& data) {
    const std::uint64_t fast = s.extract_raw(data.data());
    const std::uint64_t slow = s.extract_raw_reference(data.data(), data.size());
    if (fast == slow) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "start " << s.start_bit << " len " << s.length
                                         << (s.byte_order == ByteOrder::BigEndian ? " BE" : " LE") << ": fast 0x" << std::hex
                                         << fast << " reference 0x" << slow;
}

}  // namespace

TEST(SignalCodec, MotorolaSpanningTwoAndThreeBytesGolden) {
    const std::vector<std::uint8_t> d{0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
    EXPECT_EQ(make(7, 16, ByteOrder::BigEndian).extract_raw(d.data()), 0x1234u);     // 2 bytes, aligned
    EXPECT_EQ(make(3, 12, ByteOrder::BigEndian).extract_raw(d.data()), 0x234u);      // 2 bytes, low nibble start
    EXPECT_EQ(make(3, 16, ByteOrder::BigEndian).extract_raw(d.data()), 0x2345u);     // 3 bytes
    EXPECT_EQ(make(12, 9, ByteOrder::BigEndian).extract_raw(d.data()), 0x145u);      // 0x34 bits 4..0 = 10100, 0x56 bits 7..4 = 0101
    EXPECT_EQ(make(23, 24, ByteOrder::BigEndian).extract_raw(d.data()), 0x56789Au);  // 3 bytes, aligned
    EXPECT_EQ(make(21, 20, ByteOrder::BigEndian).extract_raw(d.data()), 0x59E26u);   // 0x56 bits 5..0, 0x78, 0x9A bits 7..2
    EXPECT_EQ(make(0, 12, ByteOrder::LittleEndian).extract_raw(d.data()), 0x412u);
    EXPECT_EQ(make(4, 16, ByteOrder::LittleEndian).extract_raw(d.data()), 0x6341u);
    // Start bits in every nibble of every byte, lengths spanning 2 and 3 bytes: fast == reference,
    // and insert writes exactly the bits the reference writes.
    std::mt19937_64 rng(12345);
    for (std::uint32_t start = 0; start < 64; ++start) {
        for (std::uint32_t len = 2; len <= 24; ++len) {
            for (ByteOrder order : {ByteOrder::BigEndian, ByteOrder::LittleEndian}) {
                Signal s;
                s.name = "S";
                s.start_bit = start;
                s.length = len;
                s.byte_order = order;
                if (s.compute_layout(8)) continue;  // does not fit
                const std::uint32_t spanned = s.layout.n_bytes;
                if (spanned < 2) continue;
                std::vector<std::uint8_t> data(8);
                for (auto& b : data) b = static_cast<std::uint8_t>(rng());
                ASSERT_TRUE(same_codec(s, data));
                const std::uint64_t raw = rng() & s.layout.mask;
                auto a = data, b = data;
                s.insert_raw(raw, a.data());
                s.insert_raw_reference(raw, b.data(), b.size());
                ASSERT_EQ(a, b) << "start " << start << " len " << len;
            }
        }
    }
}

TEST(SignalCodec, SignExtensionAndFactors) {
    Signal s = make(0, 12, ByteOrder::LittleEndian, true);
    s.factor = 0.5;
    s.offset = 10;
    EXPECT_EQ(s.raw_to_physical(0x800), -2048 * 0.5 + 10);
    EXPECT_EQ(s.raw_to_physical(0x7FF), 2047 * 0.5 + 10);
    EXPECT_EQ(s.raw_to_physical(0xFFF), -0.5 + 10);
    EXPECT_EQ(s.physical_to_raw(9.5), 0xFFFu);
    EXPECT_EQ(s.physical_to_raw(-1014.0), 0x800u);
    EXPECT_THAT([&] { (void)s.physical_to_raw(-1014.5); },
                ::testing::ThrowsMessage<CanError>(HasSubstr("signal 'S': value -1014.5 needs raw -2049, outside the 12-bit signed range [-1014, 1033.5]")));
    Signal u = make(0, 4, ByteOrder::LittleEndian, false);
    EXPECT_THAT([&] { (void)u.physical_to_raw(16); }, ::testing::ThrowsMessage<CanError>(HasSubstr("outside the 4-bit unsigned range [0, 15]")));
    EXPECT_THAT([&] { (void)u.physical_to_raw(NAN); }, ::testing::ThrowsMessage<CanError>(HasSubstr("is not finite")));
    Signal s64 = make(0, 64, ByteOrder::LittleEndian, true);
    EXPECT_EQ(s64.raw_to_physical(~std::uint64_t{0}), -1.0);
    Signal s1 = make(7, 1, ByteOrder::BigEndian, true);
    EXPECT_EQ(s1.raw_to_physical(1), -1.0);
}

TEST(SignalCodec, FloatSignals) {
    Signal f = make(8, 32, ByteOrder::LittleEndian, true);
    f.value_type = ValueType::Float32;
    std::vector<std::uint8_t> d(8);
    f.insert_raw(f.physical_to_raw(1.65e-4), d.data());
    EXPECT_EQ(f.raw_to_physical(f.extract_raw(d.data())), static_cast<double>(1.65e-4f));
    // 1.0f = 0x3F800000, little-endian from byte 1.
    f.insert_raw(f.physical_to_raw(1.0), d.data());
    EXPECT_EQ(d[1], 0x00);
    EXPECT_EQ(d[4], 0x3F);
    EXPECT_THAT([&] { (void)f.physical_to_raw(1e39); }, ::testing::ThrowsMessage<CanError>(HasSubstr("overflows float32")));
    Signal g = make(7, 64, ByteOrder::BigEndian, true);
    g.value_type = ValueType::Float64;
    g.insert_raw(g.physical_to_raw(-2.5), d.data());
    EXPECT_EQ(d[0], 0xC0);  // -2.5 = 0xC004000000000000
    EXPECT_EQ(d[1], 0x04);
    EXPECT_EQ(g.raw_to_physical(g.extract_raw(d.data())), -2.5);
}

TEST(SignalCodec, PropertyFastCodecMatchesBitByBitReference) {
    const std::uint64_t seed = env_u64("EMADIAG_PROPERTY_SEED", 20240601);
    const std::uint64_t count = env_u64("EMADIAG_PROPERTY_COUNT", 200000);
    std::cout << "[ property ] seed " << seed << ", count " << count
              << " (override with EMADIAG_PROPERTY_SEED / EMADIAG_PROPERTY_COUNT)\n";
    RecordProperty("seed", std::to_string(seed));
    std::mt19937_64 rng(seed);
    std::uint64_t checked = 0;
    for (std::uint64_t i = 0; i < count; ++i) {
        static constexpr std::size_t kLens[] = {1, 2, 4, 8, 12, 16, 20, 24, 32, 48, 64};
        const std::size_t msg_len = kLens[rng() % std::size(kLens)];
        Signal s;
        s.name = "P";
        s.byte_order = (rng() & 1) ? ByteOrder::BigEndian : ByteOrder::LittleEndian;
        s.is_signed = rng() & 1;
        s.length = static_cast<std::uint32_t>(1 + rng() % 64);
        s.start_bit = static_cast<std::uint32_t>(rng() % (msg_len * 8));
        s.factor = (rng() & 1) ? 1.0 : 0.25;
        if (s.compute_layout(msg_len)) continue;
        std::vector<std::uint8_t> data(msg_len);
        for (auto& b : data) b = static_cast<std::uint8_t>(rng());
        ASSERT_TRUE(same_codec(s, data)) << "case " << i << " seed " << seed;
        // encode -> decode gives the raw back, and only the signal's bits change.
        const std::uint64_t raw = rng() & s.layout.mask;
        auto fast = data, slow = data;
        s.insert_raw(raw, fast.data());
        s.insert_raw_reference(raw, slow.data(), slow.size());
        ASSERT_EQ(fast, slow) << "case " << i << " seed " << seed;
        ASSERT_EQ(s.extract_raw(fast.data()), raw) << "case " << i << " seed " << seed;
        // physical round trip where the double is exact (|raw| < 2^53)
        if (s.length <= 52) {
            const double phys = s.raw_to_physical(raw);
            ASSERT_EQ(s.physical_to_raw(phys), raw) << "case " << i << " seed " << seed;
        }
        ++checked;
    }
    std::cout << "[ property ] " << checked << " signals checked\n";
    EXPECT_GT(checked, count / 4);
}

TEST(Crc8J1850, CheckValueAndTableMatchesBitwise) {
    const std::string check = "123456789";
    const auto* p = reinterpret_cast<const std::uint8_t*>(check.data());
    EXPECT_EQ(crc8_j1850(p, check.size()), 0x4B);
    EXPECT_EQ(crc8_j1850_bitwise(p, check.size()), 0x4B);
    std::mt19937_64 rng(7);
    for (int i = 0; i < 1000; ++i) {
        std::vector<std::uint8_t> d(rng() % 16);
        for (auto& b : d) b = static_cast<std::uint8_t>(rng());
        ASSERT_EQ(crc8_j1850(d.data(), d.size()), crc8_j1850_bitwise(d.data(), d.size()));
    }
}
