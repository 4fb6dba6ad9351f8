#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <string>

#include "penumbra/ies_profile.h"
#include "penumbra/light.h"
#include "penumbra/math.h"
#include "scratch_directory.h"
#include "transforms.h"

using namespace penumbra;

namespace {

constexpr float kDegree = kPi / 180;

/// An LM-63-2002 profile with `header` numbers after TILT=NONE.
std::string profile(const std::string& numbers, const std::string& tilt = "TILT=NONE") {
  return "IESNA:LM-63-2002\n[TEST] penumbra\n[MANUFAC] none\n" + tilt + "\n" + numbers;
}

}  // namespace

TEST(IesProfile, ARotationallySymmetricProfileInterpolatesOverTheVerticalAngles) {
  // 1 lamp, -1 lumens (absolute), multiplier 2, 3 vertical angles, 1 horizontal, type C.
  const IesProfile ies =
      IesProfile::parse(profile("1 -1 2 3 1 1 2 0 0 0\n1.0 1.0 100\n0 45 90\n0\n100 50 0\n"));
  EXPECT_FLOAT_EQ(ies.candela(0, 0), 200);
  EXPECT_FLOAT_EQ(ies.candela(22.5f * kDegree, 1.0f), 150);  // halfway, any horizontal angle
  EXPECT_FLOAT_EQ(ies.candela(45 * kDegree, 4.0f), 100);
  EXPECT_FLOAT_EQ(ies.candela(120 * kDegree, 0), 0);  // above the vertical angles given
}

TEST(IesProfile, TheMeanIsOverTheHemisphereOrTheSphereTheAnglesCover) {
  // Constant 10 cd over 0–90°: the hemisphere's mean is 10; over 0–180°: the sphere's.
  const IesProfile down =
      IesProfile::parse(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10 10\n"));
  EXPECT_NEAR(down.meanCandela(), 10, 0.02);
  const IesProfile round =
      IesProfile::parse(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 180\n0\n10 10\n"));
  EXPECT_NEAR(round.meanCandela(), 10, 0.02);
  // Linear in θ from 10 at the nadir to 0 at 90°: the hemisphere's mean of 10 (1 − 2θ/π) is
  // 10 (1 − 2/π).
  const IesProfile falling =
      IesProfile::parse(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10 0\n"));
  EXPECT_NEAR(falling.meanCandela(), 10 * (1 - 2 / kPi), 0.01);
}

TEST(IesProfile, HorizontalSymmetriesMirrorTheAnglesGiven) {
  // One vertical angle; candelas rising with the horizontal angle (angles in float radians:
  // within 1e-3 cd).
  const IesProfile quadrant =
      IesProfile::parse(profile("1 -1 1 1 3 1 2 0 0 0\n1 1 0\n0\n0 45 90\n0 45 90\n"));
  EXPECT_NEAR(quadrant.candela(0, 30 * kDegree), 30, 1e-3);
  EXPECT_NEAR(quadrant.candela(0, 150 * kDegree), 30, 1e-3);  // mirrored about 90°
  EXPECT_NEAR(quadrant.candela(0, 200 * kDegree), 20, 1e-3);  // and about 180°
  EXPECT_NEAR(quadrant.candela(0, 330 * kDegree), 30, 1e-3);
  const IesProfile bilateral =
      IesProfile::parse(profile("1 -1 1 1 3 1 2 0 0 0\n1 1 0\n0\n0 90 180\n0 90 180\n"));
  EXPECT_NEAR(bilateral.candela(0, 135 * kDegree), 135, 1e-3);
  EXPECT_NEAR(bilateral.candela(0, 225 * kDegree), 135, 1e-3);  // mirrored about 0–180°
  const IesProfile across90 =
      IesProfile::parse(profile("1 -1 1 1 3 1 2 0 0 0\n1 1 0\n0\n90 180 270\n90 180 270\n"));
  EXPECT_NEAR(across90.candela(0, 30 * kDegree), 150, 1e-3);   // mirrored to 150°
  EXPECT_NEAR(across90.candela(0, 300 * kDegree), 240, 1e-3);  // mirrored to 240°
  const IesProfile turn =
      IesProfile::parse(profile("1 -1 1 1 4 1 2 0 0 0\n1 1 0\n0\n0 90 180 270\n0 90 180 270\n"));
  EXPECT_NEAR(turn.candela(0, 315 * kDegree), 135, 1e-3);  // from 270° back round to 0°
  EXPECT_NEAR(turn.candela(0, -45 * kDegree), 135, 1e-3);
}

TEST(IesProfile, ATiltTableIsSkippedAndCommasSeparateNumbers) {
  const IesProfile ies = IesProfile::parse(
      profile("1\n2\n0 90\n1, 0.5\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n7, 3\n", "TILT=INCLUDE"));
  EXPECT_FLOAT_EQ(ies.candela(0, 0), 7);
  EXPECT_FLOAT_EQ(ies.candela(90 * kDegree, 0), 3);
}

TEST(IesProfile, UnusableProfilesAreRejectedSayingWhy) {
  const auto message = [](const std::string& text) {
    try {
      IesProfile::parse(text);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("parsed");
  };
  EXPECT_EQ(message("IESNA:LM-63-2002\n1 2 3\n"),
            "there is no TILT= line (not an IES LM-63 profile)");
  EXPECT_EQ(message(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10\n")),
            "the file ends before a candela value");
  EXPECT_EQ(message(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n90 0\n0\n10 10\n")),
            "vertical angles must increase");
  EXPECT_EQ(message(profile("1 -1 1 2 1 2 2 0 0 0\n1 1 0\n0 90\n0\n10 10\n")),
            "photometric type 2 is not supported (only type C, 1)");
  EXPECT_EQ(message(profile("1 -1 1 2 1 1e300 2 0 0 0\n1 1 0\n0 90\n0\n10 10\n")),
            "photometric type 1e+300 is not supported (only type C, 1)");
  EXPECT_EQ(message(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10 nan\n")),
            "a candela value 'nan' is not a finite number");
  EXPECT_EQ(message(profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10 -1\n")),
            "candela values times the multiplier and ballast factors must lie in [0, 3e38]");
  EXPECT_EQ(message(profile("1 -1 1 0 1 1 2 0 0 0\n1 1 0\n0\n")),
            "the number of vertical angles must be a whole number from 1 to 100000");
}

class IesProfileFile : public test::ScratchDirectoryTest {};

TEST_F(IesProfileFile, ReadingNamesTheFile) {
  const std::string path = this->path("lamp.ies");
  std::ofstream(path) << profile("1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n10\n");
  try {
    IesProfile::read(path);
    FAIL() << "read a truncated profile";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()),
              "the IES profile " + path + " is unusable: the file ends before a candela value");
  }
  EXPECT_THROW(IesProfile::read(this->path("missing.ies")), std::invalid_argument);
}

TEST(IesProfile, ALightsProfileShapesItsEmissionInTheLightsFrame) {
  // Rising with the vertical angle (10 cd at the nadir, 100 at 90°), the same all round.
  const auto ies = std::make_shared<const IesProfile>(
      IesProfile::parse(profile("1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 90 180\n0\n10 100 100\n")));
  LightParams point;
  point.type = LightType::Sphere;
  point.radius = 0;  // radiant intensity color · intensity / 4
  point.lightToWorld = test::facingDown(0, 2, 0);
  const auto radianceAt = [&](const LightParams& params, const Vec3f& receiver) {
    return Light(params).sample(receiver, {0.5f, 0.5f})->radiance.x;
  };
  const float bare = radianceAt(point, {0, 0, 0});
  EXPECT_FLOAT_EQ(bare, 0.25f / 4);
  LightParams shaped = point;
  shaped.ies = ies;
  EXPECT_FLOAT_EQ(radianceAt(shaped, {0, 0, 0}) / bare, 10);  // the nadir: -Z, turned down
  // 45° off the nadir: halfway from 10 to 100 cd (at √8 from the lamp).
  EXPECT_NEAR(radianceAt(shaped, {2, 0, 0}) / radianceAt(point, {2, 0, 0}), 55, 1e-3);
  shaped.iesAngleScale = 1;  // θ → (θ − π) / 2 + π: the nadir reads 90°
  EXPECT_NEAR(radianceAt(shaped, {0, 0, 0}) / bare, 100, 1e-3);
  shaped.iesAngleScale = -3;  // clipped to -1: every direction but the zenith reads the nadir
  EXPECT_NEAR(radianceAt(shaped, {2, 0, 0}) / radianceAt(point, {2, 0, 0}), 10, 1e-3);
  shaped.iesAngleScale = 0;
  shaped.iesNormalize = true;  // divided by the sphere's mean candela
  EXPECT_NEAR(radianceAt(shaped, {0, 0, 0}) / bare, 10 / ies->meanCandela(), 1e-5);
  // The light tree weighs the light by the profile's mean factor.
  LightParams unnormalized = shaped;
  unnormalized.iesNormalize = false;
  EXPECT_NEAR(Light(unnormalized).bounds().power / Light(point).bounds().power, ies->meanCandela(),
              1e-3 * ies->meanCandela());
  EXPECT_NEAR(Light(shaped).bounds().power, Light(point).bounds().power, 1e-6);
  shaped.iesAngleScale = std::nanf("");
  EXPECT_THROW(Light{shaped}, std::invalid_argument);
}

TEST(IesProfile, HorizontalAngleZeroIsTheLightsMinusX) {
  // 100 cd towards horizontal angle 0 only (90°, 180° and 270° dark), at every vertical angle.
  const auto ies = std::make_shared<const IesProfile>(IesProfile::parse(profile(
      "1 -1 1 2 5 1 2 0 0 0\n1 1 0\n0 180\n0 90 180 270 360\n100 100 0 0 0 0 0 0 100 100\n")));
  LightParams point;
  point.type = LightType::Sphere;
  point.radius = 0;
  point.ies = ies;
  point.lightToWorld = test::translation(0, 0, 0);  // -Z is the nadir; -X is angle 0
  const Light light(point);
  EXPECT_GT(light.sample({-1, 0, -1}, {0.5f, 0.5f})->radiance.x, 0);
  EXPECT_EQ(light.sample({1, 0, -1}, {0.5f, 0.5f})->radiance.x, 0);
  EXPECT_EQ(light.sample({0, -1, -1}, {0.5f, 0.5f})->radiance.x, 0);  // 90°: towards -Y
}

TEST(IesProfile, RealWorldSpellingsParse) {
  // Commas alone between numbers, CR line ends (old Mac files), "tilt = none" in lower case,
  // and "TILT= INCLUDE" with a space.
  const std::string numbers = "1,-1,1,2,1,1,2,0,0,0\r1,1,0\r0,90\r0\r7,3\r";
  EXPECT_NEAR(IesProfile::parse("IESNA:LM-63-1995\rtilt = none\r" + numbers).candela(0, 0), 7,
              1e-6);
  const IesProfile tilted = IesProfile::parse(
      "IESNA:LM-63-2002\nTILT= INCLUDE\n1\n2\n0 90\n1 0.5\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n"
      "7 3\n");
  EXPECT_NEAR(tilted.candela(kPi / 2, 0), 3, 1e-6);
  // The ballast and ballast-lamp factors scale the candelas as the multiplier does.
  EXPECT_NEAR(
      IesProfile::parse(profile("1 -1 2 2 1 1 2 0 0 0\n0.5 3 0\n0 90\n0\n7 3\n")).candela(0, 0),
      7 * 2 * 0.5 * 3, 1e-5);
}

TEST(IesProfile, CountsTheFileCannotHoldAreRefusedBeforeAllocating) {
  try {
    IesProfile::parse(profile("1 -1 1 100000 100000 1 2 0 0 0\n1 1 0\n0 90\n0\n7 3\n"));
    FAIL() << "parsed";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()),
              "the file is too short for its 100000 x 100000 candela values");
  }
}

TEST(IesProfile, TheMeanOfANarrowBeamIsExact) {
  // 100 cd at the nadir falling linearly to 0 at 1°: its hemisphere mean is
  // ∫ 100 (1 − θ/a) sin θ dθ over [0, a] = 100 (1 − sin(a)/a), a = 1°.
  const IesProfile beam =
      IesProfile::parse(profile("1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 1 90\n0\n100 0 0\n"));
  const double a = kPi / 180;
  EXPECT_NEAR(beam.meanCandela() / (100 * (1 - std::sin(a) / a)), 1, 1e-4);
}

TEST(IesProfile, ANormalisedProfileOfTinyCandelasStaysFinite) {
  const auto ies = std::make_shared<const IesProfile>(
      IesProfile::parse(profile("1 -1 1e-39 2 1 1 2 0 0 0\n1 1 0\n0 180\n0\n1 1\n")));
  LightParams point;
  point.type = LightType::Sphere;
  point.radius = 0;
  point.ies = ies;
  point.iesNormalize = true;
  point.lightToWorld = test::translation(0, 0, 0);
  const float radiance = Light(point).sample({0, 0, -1}, {0.5f, 0.5f})->radiance.x;
  EXPECT_NEAR(radiance, 0.25f, 1e-4f);  // I/4 at 1 unit, the profile normalised to 1
}
