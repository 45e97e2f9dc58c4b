// One libFuzzer target; EMADIAG_FUZZ_ENTRY names the entry point of fuzz_entries.hpp it drives.
#include "fuzz/fuzz_entries.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    emadiag::fuzz::EMADIAG_FUZZ_ENTRY(data, size);
    return 0;
}
