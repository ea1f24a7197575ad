#pragma once
// Where the sun is: azimuth and elevation for a UTC time and a place on Earth (NOAA solar
// calculator equations, after Meeus; about 0.01° for years 1800–2100), and ISO 8601 times.
#include <chrono>
#include <string>

#include <Eigen/Core>

namespace skylit::sky {

using Vec3 = Eigen::Vector3d;

struct SolarPosition {
  double azimuth_rad = 0;    // from north towards east, in [0, 2π)
  double elevation_rad = 0;  // above the horizon, apparent (standard atmospheric refraction added)
  // Unit direction towards the sun in the site frame (x east, y north, z up):
  // (sin az cos el, cos az cos el, sin el).
  Vec3 direction() const;
};

// Sun position seen from (latitude_deg north, longitude_deg east) at `utc`. InputError naming
// the field when latitude is outside [-90, 90] or longitude outside [-180, 180] (or not finite).
SolarPosition solar_position(std::chrono::sys_seconds utc, double latitude_deg, double longitude_deg);

// ISO 8601 date and time with a zone: "2026-06-21T09:30:00Z", "2026-06-21T18:30:00+09:00",
// "2026-06-21 09:30Z" (seconds optional, ' ' accepted for 'T', offsets ±hh:mm or ±hhmm,
// fractions of a second dropped). InputError naming the value and the expected form otherwise;
// a time without a zone is refused rather than guessed.
std::chrono::sys_seconds parse_utc(const std::string& text);

// "YYYY-MM-DDTHH:MM:SSZ" (parse_utc reads it back).
std::string format_utc(std::chrono::sys_seconds utc);

// A time step of a time-lapse: "30min", "10s", "1h", "1.5h", "90 s" (units s, sec, m, min, h),
// a whole number of seconds from 1 s to a year. InputError naming the value and the form
// otherwise (callers add the option or field it came from).
std::chrono::seconds parse_interval(const std::string& text);

}  // namespace skylit::sky
