#include "station/render/gl_context.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

#include "station/render/render_error.h"

namespace ves::render {
namespace {

// Runs `make` and returns the RenderError's message ("" when none was thrown).
template <typename F>
std::string RenderErrorOf(F make) {
  try {
    make();
  } catch (const RenderError& error) {
    return error.what();
  }
  return "";
}

TEST(GlContext, GivesAnOpenGlEs3ContextWithoutAWindow) {
  GlContext context;
  EXPECT_EQ(context.version().rfind("OpenGL ES 3", 0), 0u) << context.version();
  EXPECT_FALSE(context.renderer().empty());
  EXPECT_NE(context.platform(), EglPlatform::kAuto);
}

TEST(GlContext, PlatformNamesParseAndUnknownOnesAreRejected) {
  EXPECT_EQ(ParseEglPlatform("surfaceless"), EglPlatform::kSurfaceless);
  EXPECT_EQ(ParseEglPlatform("device"), EglPlatform::kDevice);
  EXPECT_STREQ(EglPlatformName(ParseEglPlatform("default")), "default");
  try {
    ParseEglPlatform("wayland-ish");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("wayland-ish"), std::string::npos);
  }
}

TEST(GlContext, EnvironmentOverrideWithABadPlatformIsAClearError) {
  ASSERT_EQ(setenv("VES_EGL_PLATFORM", "no-such-platform", 1), 0);
  EXPECT_THROW(GlContext(), std::invalid_argument);
  unsetenv("VES_EGL_PLATFORM");
}

TEST(GlContext, MissingEglDeviceIsNamed) {
  GlContextOptions options;
  options.platform = EglPlatform::kDevice;
  options.device_index = 99;
  const std::string message = RenderErrorOf([&] { GlContext context(options); });
  EXPECT_NE(message.find("EGL platform device: no EGL display"), std::string::npos) << message;
}

TEST(GlContext, UnavailableEsVersionIsNamed) {
  GlContextOptions options;
  options.gles_major_version = 9;
  const std::string message = RenderErrorOf([&] { GlContext context(options); });
  EXPECT_NE(message.find("no OpenGL ES 9.0 context"), std::string::npos) << message;
}

// No EGL implementation at all: libglvnd finds no vendor library, as on a
// machine without Mesa or a GPU driver. Runs in a fresh process (the vendor
// list is read once per process); the child prints the error and exits 3.
TEST(GlContextDeathTest, NoEglImplementationIsAClearErrorNotACrash) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        setenv("__EGL_VENDOR_LIBRARY_FILENAMES", "/nonexistent/ves_no_vendor.json", 1);
        unsetenv("VES_EGL_PLATFORM");
        try {
          GlContext context;
        } catch (const RenderError& error) {
          std::cerr << error.what() << std::endl;
          std::exit(3);
        }
        std::exit(0);
      },
      ::testing::ExitedWithCode(3), "no usable EGL/OpenGL ES display");
}

}  // namespace
}  // namespace ves::render
