// Solar position from the NOAA solar calculator (Global Monitoring Laboratory spreadsheet,
// after Meeus, "Astronomical Algorithms"), and ISO 8601 time parsing.
#include "skylit/sky/solar.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <regex>

#include "skylit/base/error.hpp"
#include "skylit/geom/angles.hpp"

namespace skylit::sky {
namespace {

using geom::kPi;
using geom::kDeg;

double wrap_degrees(double degrees) {
  const double wrapped = std::fmod(degrees, 360.0);
  return wrapped < 0 ? wrapped + 360.0 : wrapped;
}

// Refraction (degrees) added to the geometric elevation, NOAA's piecewise fit for a standard
// atmosphere (Bennett above 5°, a polynomial near the horizon, a small term below it).
double refraction_degrees(double elevation_deg) {
  if (elevation_deg > 85.0) return 0.0;
  const double e = elevation_deg;
  double arcsec = 0;
  if (e > 5.0) {
    const double t = std::tan(e * kDeg);
    arcsec = 58.1 / t - 0.07 / (t * t * t) + 0.000086 / std::pow(t, 5);
  } else if (e > -0.575) {
    arcsec = 1735.0 + e * (-518.2 + e * (103.4 + e * (-12.79 + e * 0.711)));
  } else {
    arcsec = -20.772 / std::tan(e * kDeg);
  }
  return arcsec / 3600.0;
}

[[noreturn]] void bad_time(const std::string& text, const std::string& problem) {
  throw InputError(input_message("", -1, -1, "time", "'" + text + "': " + problem,
                                 "write an ISO 8601 time with a zone, e.g. 2026-06-21T09:30:00Z or "
                                 "2026-06-21T18:30:00+09:00"));
}

}  // namespace

Vec3 SolarPosition::direction() const {
  const double c = std::cos(elevation_rad);
  return {std::sin(azimuth_rad) * c, std::cos(azimuth_rad) * c, std::sin(elevation_rad)};
}

SolarPosition solar_position(std::chrono::sys_seconds utc, double latitude_deg, double longitude_deg) {
  if (!std::isfinite(latitude_deg) || latitude_deg < -90.0 || latitude_deg > 90.0) {
    throw InputError(input_message("", -1, -1, "latitude", "got " + std::to_string(latitude_deg) +
                                                               ", outside [-90, 90]",
                                   "give degrees north (negative south), e.g. 34.68"));
  }
  if (!std::isfinite(longitude_deg) || longitude_deg < -180.0 || longitude_deg > 180.0) {
    throw InputError(input_message("", -1, -1, "longitude", "got " + std::to_string(longitude_deg) +
                                                                ", outside [-180, 180]",
                                   "give degrees east (negative west), e.g. 135.84"));
  }
  // The spreadsheet's column names, in its order. UTC stands in for TT (ΔT ≈ 70 s moves the sun
  // by under 0.001°).
  const double unix_seconds = static_cast<double>(utc.time_since_epoch().count());
  const double julian_day = unix_seconds / 86400.0 + 2440587.5;
  const double jc = (julian_day - 2451545.0) / 36525.0;  // Julian centuries since J2000.0

  const double mean_long = wrap_degrees(280.46646 + jc * (36000.76983 + jc * 0.0003032));
  const double mean_anom = 357.52911 + jc * (35999.05029 - 0.0001537 * jc);
  const double ecc = 0.016708634 - jc * (0.000042037 + 0.0000001267 * jc);
  const double m = mean_anom * kDeg;
  const double eq_of_ctr = std::sin(m) * (1.914602 - jc * (0.004817 + 0.000014 * jc)) +
                           std::sin(2 * m) * (0.019993 - 0.000101 * jc) + std::sin(3 * m) * 0.000289;
  const double true_long = mean_long + eq_of_ctr;
  const double omega = (125.04 - 1934.136 * jc) * kDeg;
  const double app_long = true_long - 0.00569 - 0.00478 * std::sin(omega);
  const double mean_obliq =
      23.0 + (26.0 + (21.448 - jc * (46.815 + jc * (0.00059 - jc * 0.001813))) / 60.0) / 60.0;
  const double obliq = (mean_obliq + 0.00256 * std::cos(omega)) * kDeg;
  const double declination = std::asin(std::sin(obliq) * std::sin(app_long * kDeg));

  const double y = std::pow(std::tan(obliq / 2), 2);
  const double l0 = mean_long * kDeg;
  const double eq_of_time_min =
      4.0 / kDeg *
      (y * std::sin(2 * l0) - 2 * ecc * std::sin(m) + 4 * ecc * y * std::sin(m) * std::cos(2 * l0) -
       0.5 * y * y * std::sin(4 * l0) - 1.25 * ecc * ecc * std::sin(2 * m));

  // fmod keeps the sign of a time before 1970; the + 2880 brings every case back to positive.
  const double minutes_of_day = std::fmod(unix_seconds, 86400.0) / 60.0;
  const double true_solar_min = std::fmod(minutes_of_day + eq_of_time_min + 4.0 * longitude_deg + 2880.0, 1440.0);
  const double hour_angle = (true_solar_min / 4.0 - 180.0) * kDeg;  // 0 at solar noon, + afternoon

  const double lat = latitude_deg * kDeg;
  const double cos_zenith = std::clamp(std::sin(lat) * std::sin(declination) +
                                           std::cos(lat) * std::cos(declination) * std::cos(hour_angle),
                                       -1.0, 1.0);
  const double elevation_deg = 90.0 - std::acos(cos_zenith) / kDeg;
  // atan2 instead of the spreadsheet's acos: defined at the poles and at the zenith.
  const double azimuth = std::atan2(-std::sin(hour_angle) * std::cos(declination),
                                    std::cos(lat) * std::sin(declination) -
                                        std::sin(lat) * std::cos(declination) * std::cos(hour_angle));

  SolarPosition position;
  position.azimuth_rad = wrap_degrees(azimuth / kDeg) * kDeg;
  position.elevation_rad = (elevation_deg + refraction_degrees(elevation_deg)) * kDeg;
  return position;
}

std::chrono::sys_seconds parse_utc(const std::string& text) {
  using namespace std::chrono;
  static const std::regex pattern(
      R"(\s*(\d{4})-(\d{2})-(\d{2})[T t](\d{2}):(\d{2})(?::(\d{2})(?:[.,]\d+)?)?\s*(?:([Zz])|([+-])(\d{2}):?(\d{2}))\s*)");
  std::smatch match;
  if (!std::regex_match(text, match, pattern)) {
    static const std::regex no_zone(R"(\s*\d{4}-\d{2}-\d{2}[T t]\d{2}:\d{2}(:\d{2}([.,]\d+)?)?\s*)");
    if (std::regex_match(text, no_zone)) bad_time(text, "no time zone");
    bad_time(text, "not an ISO 8601 date and time");
  }
  const auto number = [&](int group) { return match[group].matched ? std::stoi(match[group].str()) : 0; };
  const year_month_day date{year{number(1)}, month{static_cast<unsigned>(number(2))},
                            day{static_cast<unsigned>(number(3))}};
  if (!date.ok()) bad_time(text, "no such date");
  const int hour = number(4);
  const int minute = number(5);
  const int second = number(6);
  if (hour > 23 || minute > 59 || second > 59) bad_time(text, "hour, minute or second out of range");
  int offset_minutes = 0;
  if (match[8].matched) {
    const int oh = number(9);
    const int om = number(10);
    if (oh > 18 || om > 59) bad_time(text, "zone offset out of range");
    offset_minutes = (match[8].str() == "-" ? -1 : 1) * (oh * 60 + om);
  }
  // Local time minus its offset is UTC.
  return sys_days{date} + hours{hour} + minutes{minute - offset_minutes} + seconds{second};
}

std::string format_utc(std::chrono::sys_seconds utc) {
  using namespace std::chrono;
  const sys_days day_start = floor<days>(utc);
  const year_month_day date{day_start};
  const hh_mm_ss<seconds> time{utc - day_start};
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%04d-%02u-%02uT%02d:%02d:%02dZ", static_cast<int>(date.year()),
                static_cast<unsigned>(date.month()), static_cast<unsigned>(date.day()),
                static_cast<int>(time.hours().count()), static_cast<int>(time.minutes().count()),
                static_cast<int>(time.seconds().count()));
  return buffer;
}

std::chrono::seconds parse_interval(const std::string& text) {
  static const std::regex pattern(R"(\s*(\d+(?:\.\d*)?)\s*(s|sec|m|min|h)\s*)");
  std::smatch match;
  if (!std::regex_match(text, match, pattern)) {
    throw InputError(input_message("", -1, -1, "", "'" + text + "' is not an interval",
                                   "write a number and a unit: 30s, 10min, 1h"));
  }
  const std::string unit = match[2].str();
  const double scale = unit == "h" ? 3600.0 : (unit == "m" || unit == "min") ? 60.0 : 1.0;
  const double seconds = std::stod(match[1].str()) * scale;
  if (!(seconds >= 1.0) || seconds > 366.0 * 86400.0) {
    throw InputError(input_message("", -1, -1, "", "'" + text + "' is under a second or over a year",
                                   "use e.g. 30s, 10min or 1h"));
  }
  return std::chrono::seconds(std::llround(seconds));
}

}  // namespace skylit::sky
