// fem_cloth_render run as a program on the recorded grasp-and-lift (test/data/small_grasp.bag,
// 106 states over 3.15 s of simulation): one frame per 1/fps of simulation time, PNGs of the
// size asked for that libpng reads back, the cloth in view, the depth frames consistent with
// the colour frames, and one clear error for a bag that is not there.
#include <gtest/gtest.h>
#include <png.h>

#include <filesystem>
#include <memory>

#include "../run_program.h"

using fem_cloth::test::runProgram;
using fem_cloth::test::TempDir;

namespace {

struct Png {
  int width = 0, height = 0, depth = 0, channels = 0;
  std::vector<std::uint8_t> data;  // rows, as stored
};

Png readPng(const std::string& path) {
  Png p;
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) return p;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return {};
  }
  png_init_io(png, file.get());
  png_read_info(png, info);
  p.width = static_cast<int>(png_get_image_width(png, info));
  p.height = static_cast<int>(png_get_image_height(png, info));
  p.depth = png_get_bit_depth(png, info);
  p.channels = png_get_channels(png, info);
  const std::size_t stride = png_get_rowbytes(png, info);
  p.data.resize(stride * p.height);
  for (int j = 0; j < p.height; ++j) png_read_row(png, p.data.data() + j * stride, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return p;
}

}  // namespace

TEST(RenderTool, FramesOfARecordedRun) {
  TempDir dir("render_tool");
  const std::string frames = dir.path("frames");
  const auto r = runProgram(FEM_CLOTH_RENDER_EXE,
                            {FEM_CLOTH_SOURCE_DIR "/test/data/small_grasp.bag", "--out", frames,
                             "--fps", "10", "--width", "160", "--height", "120", "--depth"},
                            dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("frames"), std::string::npos) << "a progress bar on stderr";
  // The bag's states are every third step (0.03 s) from 0 to 3.15 s: at 10 frames a second the
  // frame times 0, 0.1, ..., 3.1 s each have a state at or just after them: 32 frames.
  int count = 0;
  while (std::filesystem::exists(frames + "/frame_" + std::string(5 - std::to_string(count).size(), '0') +
                                 std::to_string(count) + ".png")) {
    ++count;
  }
  EXPECT_EQ(count, 32) << r.out;
  const Png first = readPng(frames + "/frame_00000.png");
  ASSERT_EQ(first.width, 160);
  ASSERT_EQ(first.height, 120);
  EXPECT_EQ(first.depth, 8);
  EXPECT_EQ(first.channels, 3);
  const Png depth = readPng(frames + "/depth_00000.png");
  ASSERT_EQ(depth.width, 160);
  EXPECT_EQ(depth.depth, 16);
  EXPECT_EQ(depth.channels, 1);
  // Where something is seen (depth > 0) the colour is not the background (48, 48, 48), and the
  // reverse; the camera that frames the cloth sees it.
  int seen = 0, mismatched = 0;
  for (int k = 0; k < 160 * 120; ++k) {
    const bool hasDepth = depth.data[2 * k] != 0 || depth.data[2 * k + 1] != 0;
    const bool background = first.data[3 * k] == 48 && first.data[3 * k + 1] == 48 && first.data[3 * k + 2] == 48;
    seen += hasDepth ? 1 : 0;
    mismatched += hasDepth == background ? 1 : 0;
  }
  EXPECT_GT(seen, 160 * 120 / 20) << "the cloth covers a good part of the image";
  EXPECT_EQ(mismatched, 0);
}

TEST(RenderTool, AMissingBagIsOneClearError) {
  TempDir dir("render_tool_missing");
  const auto r = runProgram(FEM_CLOTH_RENDER_EXE, {dir.path("nothing.bag"), "--out", dir.path("f")}, dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no bag at"), std::string::npos) << r.err;
}
