// Runs a fuzz target without libFuzzer (g++ has none): its seeds, then mutations of them --
// bit flips, random bytes, extreme 32- and 64-bit values (lengths, counts, offsets) at every
// position, truncations, extensions and spliced copies -- from a fixed random seed, so a ctest run
// is reproducible. Under the asan-ubsan preset every input runs with ASan and UBSan.
//
// usage: fuzz_driver [--iterations N] [--seed S] [--write-corpus DIR] [FILE...]
// FILE arguments are run as they are (a crash input libFuzzer found, say).

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

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

void mutate(Bytes& b, const std::vector<Bytes>& pool, std::mt19937_64& rng) {
  const auto pick = [&](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng() % n); };
  switch (rng() % 7) {
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
    default:
      if (b.size() > 1) b.erase(b.begin() + static_cast<std::ptrdiff_t>(pick(b.size())));
      break;
  }
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
    for (const Bytes& f : files) LLVMFuzzerTestOneInput(f.data(), f.size());
    std::printf("fuzz_driver: %zu files ran\n", files.size());
    return 0;
  }
  for (const Bytes& s : seeds) LLVMFuzzerTestOneInput(s.data(), s.size());
  std::mt19937_64 rng(seed);
  for (long i = 0; i < iterations; ++i) {
    Bytes b = seeds[static_cast<std::size_t>(rng() % seeds.size())];
    const int rounds = 1 + static_cast<int>(rng() % 4);
    for (int r = 0; r < rounds; ++r) mutate(b, seeds, rng);
    LLVMFuzzerTestOneInput(b.data(), b.size());
  }
  std::printf("fuzz_driver: %zu seeds and %ld mutated inputs ran\n", seeds.size(), iterations);
  return 0;
}
