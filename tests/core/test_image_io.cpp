#include "dco/core/image_io.hpp"

#include <iterator>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

Image<std::uint8_t> pattern(int w, int h, int c) {
  Image<std::uint8_t> img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        img.at(x, y, k) = static_cast<std::uint8_t>(x * 3 + y * 5 + k * 70);
  return img;
}

void expect_equal(const Image<std::uint8_t>& a, const Image<std::uint8_t>& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  ASSERT_EQ(a.channels(), b.channels());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int k = 0; k < a.channels(); ++k) ASSERT_EQ(a.at(x, y, k), b.at(x, y, k));
}

std::string error_of(const std::filesystem::path& p) {
  try {
    load_image(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ImageIo, GreyAndColourRoundTrip) {
  test::TempDir dir;
  const auto grey = pattern(31, 17, 1);
  const auto colour = pattern(31, 17, 3);
  save_image(dir / "g.png", grey.cview());
  save_image(dir / "c.png", colour.cview());
  save_image(dir / "g.pgm", grey.cview());
  expect_equal(grey, load_image(dir / "g.png"));
  expect_equal(colour, load_image(dir / "c.png"));
  expect_equal(grey, load_image(dir / "g.pgm"));
}

TEST(ImageIo, ColourConversions) {
  test::TempDir dir;
  const auto colour = pattern(8, 4, 3);
  save_image(dir / "c.png", colour.cview());
  const auto grey = load_image(dir / "c.png", ImageColor::kGray);
  EXPECT_EQ(grey.channels(), 1);
  EXPECT_EQ(load_image(dir / "c.png", ImageColor::kColor).channels(), 3);

  save_image(dir / "g.png", grey.cview());
  const auto expanded = load_image(dir / "g.png", ImageColor::kColor);
  ASSERT_EQ(expanded.channels(), 3);
  EXPECT_EQ(expanded.at(5, 2, 0), grey.at(5, 2));
  EXPECT_EQ(expanded.at(5, 2, 2), grey.at(5, 2));
  EXPECT_EQ(load_image(dir / "g.png").channels(), 1);
}

TEST(ImageIo, AlphaIsDropped) {
  test::TempDir dir;
  cv::Mat bgra(3, 3, CV_8UC4, cv::Scalar(10, 20, 30, 128));
  ASSERT_TRUE(cv::imwrite((dir / "a.png").string(), bgra));
  const auto img = load_image(dir / "a.png");
  ASSERT_EQ(img.channels(), 3);
  EXPECT_EQ(img.at(1, 1, 2), 30);
}

TEST(ImageIo, SavesStridedSubView) {
  test::TempDir dir;
  const auto big = pattern(40, 30, 1);
  save_image(dir / "sub.png", big.cview().sub(5, 7, 11, 9));
  const auto back = load_image(dir / "sub.png");
  ASSERT_EQ(back.width(), 11);
  EXPECT_EQ(back.at(0, 0), big.at(5, 7));
  EXPECT_EQ(back.at(10, 8), big.at(15, 15));
}

TEST(ImageIo, ErrorsNameTheFile) {
  test::TempDir dir;
  EXPECT_NE(error_of(dir / "missing.png").find("missing.png"), std::string::npos);
  test::write_file(dir / "garbage.png", "this is not a PNG");
  EXPECT_NE(error_of(dir / "garbage.png").find("garbage.png"), std::string::npos);
  cv::Mat deep(4, 4, CV_16UC1, cv::Scalar(1000));
  ASSERT_TRUE(cv::imwrite((dir / "deep.png").string(), deep));
  const std::string msg = error_of(dir / "deep.png");
  EXPECT_NE(msg.find("deep.png"), std::string::npos);
  EXPECT_NE(msg.find("16-bit"), std::string::npos) << msg;
  EXPECT_NE(error_of(dir.path()).find("not a regular file"), std::string::npos);

  const auto img = pattern(4, 4, 1);
  EXPECT_THROW(save_image(dir / "no" / "such" / "dir.png", img.cview()), Error);
  EXPECT_THROW(save_image(dir / "noext", img.cview()), Error);
  EXPECT_THROW(save_image(dir / "empty.png", ImageView<const std::uint8_t>()), Error);
}

// A small PNG that claims 20000 x 20000 pixels is refused from its header, before OpenCV would
// allocate the whole image.
TEST(ImageIo, HugePngIsRefusedFromItsHeader) {
  test::TempDir dir;
  const unsigned char header[] = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1a, '\n', 0,    0, 0,
                                  13,   'I',  'H', 'D', 'R',  0,    0,    0x4e, 0x20, 0, 0,
                                  0x4e, 0x20, 8,   2,   0,    0,    0,    0,    0,    0, 0};
  test::write_file(dir / "huge.png", std::string(std::begin(header), std::end(header)));
  EXPECT_NE(error_of(dir / "huge.png").find("huge.png' is a 20000x20000 PNG (sides at most 16384)"),
            std::string::npos)
      << error_of(dir / "huge.png");
}

// A PNG cut short or with a damaged byte is refused from its chunks, before libpng decodes it
// (which would also print its own line on stderr); every cut and every flipped byte is found.
TEST(ImageIo, APngCutShortOrDamagedIsRefusedFromItsChunks) {
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", as_mat(pattern(40, 30, 3).cview()), png));
  EXPECT_EQ(png_damage(png), "");
  for (std::size_t cut = 0; cut < png.size(); ++cut) {
    const std::span<const std::uint8_t> head(png.data(), cut);
    EXPECT_NE(png_damage(head).find(cut < 8 ? "shorter than" : "cut short"), std::string::npos)
        << cut << ": " << png_damage(head);
  }
  for (std::size_t at = 8; at < png.size(); ++at) {
    std::vector<std::uint8_t> flipped = png;
    flipped[at] ^= 0x10;
    EXPECT_NE(png_damage(flipped), "") << "byte " << at;
  }
  test::TempDir dir;
  test::write_file(
      dir / "cut.png",
      std::string(png.begin(), png.begin() + static_cast<std::ptrdiff_t>(png.size() / 2)));
  EXPECT_NE(error_of(dir / "cut.png").find("cut.png': the PNG is cut short"), std::string::npos)
      << error_of(dir / "cut.png");
}

// A PGM of fewer levels than 8 bits give (maxval 15) would come out as values 0..15: refused,
// where one of maxval 255, comments in its header, loads.
TEST(ImageIo, APgmOfFewerLevelsIsRefused) {
  test::TempDir dir;
  const auto write = [&](const std::string& name, const std::string& header) {
    std::ofstream out(dir.path() / name, std::ios::binary);
    out << header << std::string(4 * 2, '\x0c');
    return dir.path() / name;
  };
  const auto low = write("low.pgm", "P5\n# four levels of grey\n4 2\n15\n");
  try {
    load_image(low, ImageColor::kGray);
    ADD_FAILURE() << "took a maxval 15 PGM";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("maxval 15"), std::string::npos) << e.what();
  }
  const Image<std::uint8_t> ok =
      load_image(write("ok.pgm", "P5 4 2 # size\n255\n"), ImageColor::kGray);
  EXPECT_EQ(ok.width(), 4);
  EXPECT_EQ(ok.cview().at(0, 0), 12);
}

TEST(ImageIo, ReadsDatasetImages) {
  const auto mb = load_image(test::data_dir() / "middlebury2014" / "Motorcycle" / "im0.png");
  EXPECT_EQ(mb.width(), 741);
  EXPECT_EQ(mb.height(), 497);
  EXPECT_EQ(mb.channels(), 3);
  const auto ka = load_image(test::data_dir() / "karlsruhe_sequences" / "2010_03_09_drive_0023" /
                             "images" / "I1_000000.png");
  EXPECT_EQ(ka.width(), 1344);
  EXPECT_EQ(ka.height(), 372);
  EXPECT_EQ(ka.channels(), 1);
}

}  // namespace
}  // namespace dco
