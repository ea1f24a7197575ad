// Solar position against a published reference and against geometry that must hold on the
// solstice and the equinox; ISO 8601 times, good and bad.
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/sky/solar.hpp"

namespace solar_test {  // named, not anonymous: the test program is one unity build

using namespace std::chrono;
using skylit::sky::format_utc;
using skylit::sky::parse_utc;
using skylit::sky::solar_position;
using skylit::sky::SolarPosition;

constexpr double kDeg = std::numbers::pi / 180.0;

double elevation_deg(const SolarPosition& p) { return p.elevation_rad / kDeg; }
double azimuth_deg(const SolarPosition& p) { return p.azimuth_rad / kDeg; }

// Highest elevation over a UTC day (to the second), and when.
std::pair<SolarPosition, sys_seconds> highest(sys_seconds day_start, double lat, double lon) {
  SolarPosition best{};
  sys_seconds when = day_start;
  best.elevation_rad = -10;
  for (int minute = 0; minute < 24 * 60; ++minute) {
    const sys_seconds t = day_start + minutes(minute);
    const SolarPosition p = solar_position(t, lat, lon);
    if (p.elevation_rad > best.elevation_rad) {
      best = p;
      when = t;
    }
  }
  // Near the zenith the sun climbs 0.25° a minute: refine to the second.
  const sys_seconds coarse = when;
  for (int second = -60; second <= 60; ++second) {
    const sys_seconds t = coarse + seconds(second);
    const SolarPosition p = solar_position(t, lat, lon);
    if (p.elevation_rad > best.elevation_rad) {
      best = p;
      when = t;
    }
  }
  return {best, when};
}

// The moment elevation crosses 0 between a and b (one crossing), to the second.
sys_seconds crossing(sys_seconds a, sys_seconds b, double lat, double lon) {
  const bool rising = solar_position(a, lat, lon).elevation_rad < 0;
  while (b - a > seconds(1)) {
    const sys_seconds mid = a + (b - a) / 2;
    const bool up = solar_position(mid, lat, lon).elevation_rad > 0;
    if (up == rising) b = mid; else a = mid;
  }
  return a;
}


// NREL's SPA report (Reda and Andreas 2004, NREL/TP-560-34302, appendix A.5): Golden, Colorado,
// 2003-10-17 12:30:30 local (UTC−7), 39.742476° N, 105.1786° W: topocentric zenith 50.11162°,
// azimuth 194.34024°. SPA uses 820 mbar and 11 °C for refraction (NOAA: a standard
// atmosphere, 0.004° more at this elevation) and a 1830 m altitude; 0.02° covers both.
TEST(SolarPosition, MatchesTheSpaReferenceCase) {
  const SolarPosition p = solar_position(parse_utc("2003-10-17T12:30:30-07:00"), 39.742476, -105.1786);
  EXPECT_NEAR(90.0 - elevation_deg(p), 50.11162, 0.02);
  EXPECT_NEAR(azimuth_deg(p), 194.34024, 0.02);
}

// June solstice 2026 (21 June, 08:24 UTC): the noon sun stands at 90° − |φ − 23.44°| (plus
// refraction, under 0.03° at these elevations), south of a northern site and north of a
// tropical or southern one.
TEST(SolarPosition, SolsticeNoonElevation) {
  const sys_seconds day = sys_days{2026y / June / 21};
  for (const double lat : {34.68, 51.48, 0.0, -33.9, 60.0, 23.44}) {
    for (const double lon : {135.84, 0.0, -120.0}) {
      SCOPED_TRACE("latitude " + std::to_string(lat) + ", longitude " + std::to_string(lon));
      // Start the day half a day before local noon so that noon falls inside it.
      const sys_seconds start = day - seconds(static_cast<long long>(lon / 15.0 * 3600.0));
      const auto [p, when] = highest(start, lat, lon);
      EXPECT_NEAR(elevation_deg(p), 90.0 - std::abs(lat - 23.44), 0.05);
      if (lat > 24.0) {
        EXPECT_NEAR(azimuth_deg(p), 180.0, 0.5);
      } else if (lat < 23.0) {
        EXPECT_NEAR(std::cos(p.azimuth_rad), 1.0, 1e-3);  // north
      }
      // Solar noon is within the equation of time (−2 min in late June) of 12:00 local mean time.
      const double noon_hours = duration<double>(when - start).count() / 3600.0;
      EXPECT_NEAR(noon_hours, 12.0, 5.0 / 60.0);
    }
  }
}

// March equinox 2026 (20 March, 14:46 UTC): the sun rises due east and sets due west, within
// the ~0.5° that refraction and the day's change of declination allow.
TEST(SolarPosition, EquinoxSunriseIsEastAndSunsetWest) {
  const sys_seconds day = sys_days{2026y / March / 20};
  for (const double lat : {34.68, -33.9, 0.0, 51.48}) {
    SCOPED_TRACE("latitude " + std::to_string(lat));
    const double lon = 0.0;
    const sys_seconds sunrise = crossing(day + hours(3), day + hours(9), lat, lon);
    const sys_seconds sunset = crossing(day + hours(15), day + hours(21), lat, lon);
    EXPECT_NEAR(azimuth_deg(solar_position(sunrise, lat, lon)), 90.0, 1.0);
    EXPECT_NEAR(azimuth_deg(solar_position(sunset, lat, lon)), 270.0, 1.0);
    // Day and night are equal, up to refraction's few minutes.
    EXPECT_NEAR(duration<double>(sunset - sunrise).count() / 3600.0, 12.0, 0.25);
  }
}

TEST(SolarPosition, MorningEastAfternoonWestAndDirection) {
  const double lat = 34.68, lon = 135.84;  // Nara; local time is UTC+9
  const SolarPosition morning = solar_position(parse_utc("2026-06-21T09:00:00+09:00"), lat, lon);
  const SolarPosition afternoon = solar_position(parse_utc("2026-06-21T15:00:00+09:00"), lat, lon);
  EXPECT_GT(morning.elevation_rad, 0.5);
  EXPECT_GT(afternoon.elevation_rad, 0.5);
  EXPECT_GT(morning.direction().x(), 0.5);     // east
  EXPECT_LT(afternoon.direction().x(), -0.5);  // west
  for (const SolarPosition& p : {morning, afternoon}) {
    const auto d = p.direction();
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    EXPECT_NEAR(std::atan2(d.x(), d.y()), std::remainder(p.azimuth_rad, 2 * std::numbers::pi), 1e-12);
    EXPECT_NEAR(std::asin(d.z()), p.elevation_rad, 1e-12);
    EXPECT_GE(p.azimuth_rad, 0.0);
    EXPECT_LT(p.azimuth_rad, 2 * std::numbers::pi);
  }
  // Midnight: below the horizon.
  EXPECT_LT(solar_position(parse_utc("2026-06-21T00:00:00+09:00"), lat, lon).elevation_rad, 0.0);
}

TEST(SolarPosition, PolesAndDateLineAreFinite) {
  const sys_seconds t = parse_utc("2026-06-21T12:00:00Z");
  for (const double lat : {90.0, -90.0}) {
    for (const double lon : {-180.0, 180.0, 0.0}) {
      const SolarPosition p = solar_position(t, lat, lon);
      EXPECT_TRUE(std::isfinite(p.azimuth_rad));
      EXPECT_TRUE(std::isfinite(p.elevation_rad));
    }
  }
  // At the north pole on the solstice the sun circles at the declination.
  EXPECT_NEAR(elevation_deg(solar_position(t, 90.0, 0.0)), 23.44, 0.05);
  // Before 1970 works too.
  const SolarPosition old = solar_position(parse_utc("1969-07-20T20:17:40Z"), 0.674, 23.473);
  EXPECT_TRUE(std::isfinite(old.elevation_rad));
}

TEST(SolarPosition, RejectsBadCoordinates) {
  const sys_seconds t = parse_utc("2026-06-21T12:00:00Z");
  for (const double lat : {90.5, -91.0, std::nan("")}) {
    try {
      solar_position(t, lat, 0.0);
      FAIL() << "latitude " << lat << " accepted";
    } catch (const skylit::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("latitude"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("Fix:"), std::string::npos) << e.what();
    }
  }
  for (const double lon : {180.5, -200.0, std::numeric_limits<double>::infinity()}) {
    EXPECT_THROW(solar_position(t, 0.0, lon), skylit::InputError);
  }
}

TEST(ParseUtc, ReadsZonesAndForms) {
  const sys_seconds z = parse_utc("2026-06-21T09:30:00Z");
  EXPECT_EQ(z, sys_days{2026y / June / 21} + hours(9) + minutes(30));
  EXPECT_EQ(parse_utc("2026-06-21T18:30:00+09:00"), z);
  EXPECT_EQ(parse_utc("2026-06-21T18:30:00+0900"), z);
  EXPECT_EQ(parse_utc("2026-06-21T04:00:00-05:30"), z);
  EXPECT_EQ(parse_utc("2026-06-21 09:30Z"), z);
  EXPECT_EQ(parse_utc("2026-06-21t09:30:00z"), z);
  EXPECT_EQ(parse_utc("2026-06-21T09:30:00.75Z"), z);
  EXPECT_EQ(parse_utc(" 2026-06-21T09:30:00+00:00 "), z);
  // Across a day and a year boundary.
  EXPECT_EQ(parse_utc("2027-01-01T01:00:00+02:00"), sys_days{2026y / December / 31} + hours(23));
  EXPECT_EQ(parse_utc("2024-02-29T00:00:00Z"), sys_seconds(sys_days{2024y / February / 29}));
}

TEST(ParseUtc, FormatRoundTrips) {
  for (const std::string text : {"2026-06-21T09:30:00Z", "1969-12-31T23:59:59Z", "2000-02-29T00:00:00Z"}) {
    EXPECT_EQ(format_utc(parse_utc(text)), text);
  }
}

TEST(ParseUtc, RejectsBadTimesNamingTheValue) {
  for (const std::string bad : {"", "yesterday", "2026-06-21T10:00:00", "2026-06-21", "2026-02-30T00:00:00Z",
                                "2026-13-01T00:00:00Z", "2026-06-21T24:00:00Z", "2026-06-21T10:60:00Z",
                                "2026-06-21T10:00:00+25:00", "2026-06-21T10:00:00 JST", "21/06/2026 10:00Z"}) {
    try {
      parse_utc(bad);
      FAIL() << "'" << bad << "' accepted";
    } catch (const skylit::InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("'" + bad + "'"), std::string::npos) << message;
      EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
    }
  }
  try {
    parse_utc("2026-06-21T10:00:00");
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no time zone"), std::string::npos) << e.what();
  }
}
}  // namespace solar_test
