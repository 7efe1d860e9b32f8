// Runs a fuzz target without libFuzzer (g++ has none): its seeds, then mutations of them --
// bit flips, random bytes, extreme 32- and 64-bit values (lengths, counts, offsets) at every
// position, truncations, extensions, spliced copies and, for text formats, extreme numbers and
// separators written out as text -- from a fixed random seed, so a ctest run is reproducible. Under
// the asan-ubsan preset every input runs with ASan and UBSan.
//
// usage: fuzz_driver [--iterations N] [--seed S] [--write-corpus DIR] [FILE...]
// FILE arguments are run as they are (a crash input libFuzzer found, say). An input that aborts or
// faults is written to fuzz-crash-input in the working directory first, to be run again that way.

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "fuzz_target.hpp"

namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint64_t kExtremes[] = {0,
                                       1,
                                       0x7f,
                                       0x80,
                                       0xff,
                                       0x7fff,
                                       0x8000,
                                       0xffff,
                                       0x10000,
                                       0x7fffffff,
                                       0x80000000,
                                       0xffffffff,
                                       0x100000000ull,
                                       0x7fffffffffffffffull,
                                       0x8000000000000000ull,
                                       0xffffffffffffffffull};

void put(Bytes& b, std::size_t at, std::uint64_t v, int bytes, bool big_endian) {
  for (int i = 0; i < bytes && at + static_cast<std::size_t>(i) < b.size(); ++i) {
    const int shift = big_endian ? 8 * (bytes - 1 - i) : 8 * i;
    b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> shift);
  }
}

// Tokens that text parsers (TOML, calibration files, PFM headers, manifests) must survive.
constexpr const char* kTextTokens[] = {"0",
                                       "-0",
                                       "-1",
                                       "1e308",
                                       "-1e308",
                                       "1e-320",
                                       "nan",
                                       "-nan",
                                       "inf",
                                       "-inf",
                                       "2147483648",
                                       "-2147483649",
                                       "18446744073709551616",
                                       "0x7fffffff",
                                       "1.5",
                                       "1e9999",
                                       "\n",
                                       "\r\n",
                                       " ",
                                       "\t",
                                       "=",
                                       ":",
                                       ",",
                                       ";",
                                       "#",
                                       "[",
                                       "]",
                                       "[[",
                                       "{",
                                       "}",
                                       "\"",
                                       "'",
                                       "\\",
                                       "\"\"\"",
                                       "true",
                                       "\xc3",
                                       "\xff\xfe"};

void put_text(Bytes& b, std::size_t at, std::string_view token, bool overwrite) {
  at = std::min(at, b.size());
  if (overwrite) {
    const std::size_t n = std::min(token.size(), b.size() - at);
    std::memcpy(b.data() + at, token.data(), n);
    b.insert(b.begin() + static_cast<std::ptrdiff_t>(at + n), token.begin() + n, token.end());
  } else {
    b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), token.begin(), token.end());
  }
}

void mutate(Bytes& b, const std::vector<Bytes>& pool, std::mt19937_64& rng) {
  const auto pick = [&](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng() % n); };
  switch (rng() % 8) {
    case 0:
      if (!b.empty()) b[pick(b.size())] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
      break;
    case 1:
      if (!b.empty()) b[pick(b.size())] = static_cast<std::uint8_t>(rng());
      break;
    case 2: {  // an extreme value over a field, either byte order (LCM big, the ring little)
      const std::uint64_t v = kExtremes[pick(std::size(kExtremes))] + (rng() % 3) - 1;
      put(b, pick(b.size()), v, rng() % 2 ? 4 : 8, rng() % 2 == 0);
      break;
    }
    case 3:
      b.resize(pick(b.size() + 1));
      break;
    case 4: {
      const std::size_t n = 1 + pick(64);
      for (std::size_t i = 0; i < n; ++i) b.push_back(static_cast<std::uint8_t>(rng()));
      break;
    }
    case 5: {  // a piece of another input at a random place
      const Bytes& other = pool[pick(pool.size())];
      if (other.empty() || b.empty()) break;
      const std::size_t from = pick(other.size());
      const std::size_t n = std::min(other.size() - from, 1 + pick(32));
      const std::size_t to = pick(b.size());
      for (std::size_t i = 0; i < n && to + i < b.size(); ++i) b[to + i] = other[from + i];
      break;
    }
    case 6:
      put_text(b, pick(b.size() + 1), kTextTokens[pick(std::size(kTextTokens))], rng() % 2 == 0);
      break;
    default:
      if (b.size() > 1) b.erase(b.begin() + static_cast<std::ptrdiff_t>(pick(b.size())));
      break;
  }
}

// The input being run, for the fatal-signal handler (which may only make system calls).
const Bytes* volatile g_running = nullptr;

extern "C" void write_crash_input(int sig) {
  const Bytes* input = g_running;
  if (input != nullptr) {
    const int fd = ::open("fuzz-crash-input", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      const ssize_t ignored = ::write(fd, input->data(), input->size());
      (void)ignored;
      ::close(fd);
    }
  }
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void run(const Bytes& input) {
  g_running = &input;
  LLVMFuzzerTestOneInput(input.data(), input.size());
  g_running = nullptr;
}

Bytes read_file(const char* path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "fuzz_driver: cannot read %s\n", path);
    std::exit(2);
  }
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

int main(int argc, char** argv) {
  long iterations = 20000;
  std::uint64_t seed = 1;
  std::string corpus_dir;
  std::vector<Bytes> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--iterations" && i + 1 < argc) {
      iterations = std::atol(argv[++i]);
    } else if (a == "--seed" && i + 1 < argc) {
      seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--write-corpus" && i + 1 < argc) {
      corpus_dir = argv[++i];
    } else if (a.rfind("--", 0) == 0) {
      std::fprintf(stderr, "usage: %s [--iterations N] [--seed S] [--write-corpus DIR] [FILE...]\n",
                   argv[0]);
      return 2;
    } else {
      files.push_back(read_file(argv[i]));
    }
  }
  for (const int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL})
    std::signal(sig, write_crash_input);
  const std::vector<Bytes> seeds = dco::fuzz::seeds();
  if (!corpus_dir.empty()) {
    std::filesystem::create_directories(corpus_dir);
    for (std::size_t i = 0; i < seeds.size(); ++i) {
      std::ofstream out(std::filesystem::path(corpus_dir) / ("seed_" + std::to_string(i)),
                        std::ios::binary);
      out.write(reinterpret_cast<const char*>(seeds[i].data()),
                static_cast<std::streamsize>(seeds[i].size()));
    }
    return 0;
  }
  if (!files.empty()) {
    for (const Bytes& f : files) run(f);
    std::printf("fuzz_driver: %zu files ran\n", files.size());
    return 0;
  }
  for (const Bytes& s : seeds) run(s);
  std::mt19937_64 rng(seed);
  for (long i = 0; i < iterations; ++i) {
    Bytes b = seeds[static_cast<std::size_t>(rng() % seeds.size())];
    const int rounds = 1 + static_cast<int>(rng() % 4);
    for (int r = 0; r < rounds; ++r) mutate(b, seeds, rng);
    run(b);
  }
  std::printf("fuzz_driver: %zu seeds and %ld mutated inputs ran\n", seeds.size(), iterations);
  return 0;
}
