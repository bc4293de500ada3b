/* sun.c — the position of the sun for a UTC instant and a place: the NOAA solar calculator's
 * algorithm (NOAA Global Monitoring Laboratory, after Meeus, "Astronomical Algorithms", 2nd ed.,
 * ch. 25 low-precision solar coordinates and ch. 28 equation of time): about 0.01 degree in
 * position and a few seconds in the equation of time for 1900-2100 (tests/world/test_sun.c
 * compares with the NREL SPA reference example and almanac values). */
#include <math.h>

#include "squall/sqmath.h"
#include "squall/world.h"

static double deg2rad(double d) { return d * (SQ_PI / 180.0); }
static double rad2deg(double r) { return r * (180.0 / SQ_PI); }

/* Days from 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil). */
static int64_t days_from_civil(int64_t y, int64_t m, int64_t d)
{
    /* normalise the month first so that month 0 or 13 roll over the year */
    y += (m - 1 >= 0 ? (m - 1) / 12 : -((12 - m) / 12));
    m = ((m - 1) % 12 + 12) % 12 + 1;
    y -= m <= 2;
    const int64_t era = (y >= 0 ? y : y - 399) / 400;
    const int64_t yoe = y - era * 400;
    const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + doe - 719468;
}

double sq_unix_time(int year, int month, int day, int hour, int minute, double second)
{
    const int64_t days = days_from_civil(year, month, day);
    return (double)days * 86400.0 + (double)hour * 3600.0 + (double)minute * 60.0 + second;
}

/* Atmospheric refraction (degrees) for a true elevation h (degrees): Saemundsson (1986) at
 * 1010 hPa and 10 C, the inverse of Bennett's formula to 0.1 arcmin. */
static double refraction_deg(double h)
{
    if (h < -1.0) return 0.0;
    const double r_arcmin = 1.02 / tan(deg2rad(h + 10.3 / (h + 5.11)));
    return r_arcmin / 60.0;
}

sq_sun_position sq_sun_position_at(double unix_time_s, double latitude_deg, double longitude_deg)
{
    sq_sun_position p;
    /* Julian centuries since J2000.0 (UTC used for TT: 69 s change the result by 0.0008 deg) */
    const double jd = unix_time_s / 86400.0 + 2440587.5;
    const double t = (jd - 2451545.0) / 36525.0;

    /* geometric mean longitude and anomaly of the sun, eccentricity of the earth's orbit */
    const double l0 = fmod(280.46646 + t * (36000.76983 + t * 0.0003032), 360.0);
    const double m = 357.52911 + t * (35999.05029 - 0.0001537 * t);
    const double e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);
    const double mr = deg2rad(m);
    /* equation of the centre -> true longitude -> apparent longitude (nutation, aberration) */
    const double c = sin(mr) * (1.914602 - t * (0.004817 + 0.000014 * t)) +
                     sin(2.0 * mr) * (0.019993 - 0.000101 * t) + sin(3.0 * mr) * 0.000289;
    const double omega = deg2rad(125.04 - 1934.136 * t);
    const double lambda = deg2rad(l0 + c - 0.00569 - 0.00478 * sin(omega));
    /* obliquity of the ecliptic, corrected for nutation */
    const double eps0 =
        23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
    const double eps = deg2rad(eps0 + 0.00256 * cos(omega));
    const double decl = asin(sin(eps) * sin(lambda));
    p.declination_deg = rad2deg(decl);

    /* equation of time (Meeus 28.3), minutes */
    const double y = tan(eps / 2.0) * tan(eps / 2.0);
    const double l0r = deg2rad(l0);
    const double eot = y * sin(2.0 * l0r) - 2.0 * e * sin(mr) +
                       4.0 * e * y * sin(mr) * cos(2.0 * l0r) - 0.5 * y * y * sin(4.0 * l0r) -
                       1.25 * e * e * sin(2.0 * mr);
    p.equation_of_time_min = 4.0 * rad2deg(eot);

    /* true solar time at the longitude and the hour angle */
    double utc_min = fmod(unix_time_s, 86400.0) / 60.0;
    if (utc_min < 0.0) utc_min += 1440.0;
    double tst = fmod(utc_min + p.equation_of_time_min + 4.0 * longitude_deg, 1440.0);
    if (tst < 0.0) tst += 1440.0;
    p.true_solar_time_h = tst / 60.0;
    double ha = tst / 4.0 - 180.0;
    p.hour_angle_deg = ha;

    /* horizontal coordinates */
    const double phi = deg2rad(latitude_deg);
    const double har = deg2rad(ha);
    const double cos_z = sq_clampd(sin(phi) * sin(decl) + cos(phi) * cos(decl) * cos(har), -1.0,
                                   1.0);
    const double zen = acos(cos_z);
    p.zenith_deg = rad2deg(zen);
    /* azimuth from north, clockwise: atan2 of the east and north components of the direction */
    const double east = -cos(decl) * sin(har);
    const double north = sin(decl) * cos(phi) - cos(decl) * sin(phi) * cos(har);
    double az = rad2deg(atan2(east, north));
    if (az < 0.0) az += 360.0;
    p.azimuth_deg = az;
    const double h = 90.0 - p.zenith_deg;
    p.elevation_deg = h + refraction_deg(h);
    return p;
}

sq_vec3 sq_sun_position_direction(const sq_sun_position *p)
{
    const double el = deg2rad(p->elevation_deg);
    const double az = deg2rad(p->azimuth_deg);
    return sq_v3((float)(cos(el) * sin(az)), (float)(cos(el) * cos(az)), (float)sin(el));
}
