/* diagnostics.csv rows; see csv.h. */
#include <stdio.h>

#include "app/io/csv.h"

int sm_csv_header(char *buf, size_t len) {
    return snprintf(buf, len,
                    "frame,time_s,steps_frame,steps_total,dt_min_s,dt_max_s,particles,total_mass_kg,com_x_m,com_y_m,"
                    "com_z_m,kinetic_energy_J,elastic_energy_J,momentum_x_kg_m_s,momentum_y_kg_m_s,momentum_z_kg_m_s,"
                    "max_speed_m_s,newton_iterations_frame,gmres_iterations_frame,newton_unconverged_total,wall_s_frame,"
                    "wall_s_total\n");
}

int sm_csv_row(char *buf, size_t len, int frame, const sm_diagnostics *d, const sm_diagnostics *prev, double wall_frame,
               double wall_total) {
    const unsigned long long steps = (unsigned long long)(d->steps - prev->steps);
    char dt[64] = ","; /* no step in the frame: dt_min_s and dt_max_s empty */
    if (steps > 0) snprintf(dt, sizeof dt, "%.6g,%.6g", d->min_dt, d->max_dt);
    return snprintf(buf, len,
                    "%d,%.9g,%llu,%llu,%s,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.6g,%llu,%llu,%llu,%.4f,%.4f\n",
                    frame, d->time, steps, (unsigned long long)d->steps, dt, d->particles, d->total_mass,
                    d->center_of_mass[0], d->center_of_mass[1], d->center_of_mass[2], d->kinetic_energy,
                    d->elastic_energy, d->momentum[0], d->momentum[1], d->momentum[2], d->max_speed,
                    (unsigned long long)(d->newton_iterations - prev->newton_iterations),
                    (unsigned long long)(d->gmres_iterations - prev->gmres_iterations),
                    (unsigned long long)d->newton_unconverged, wall_frame, wall_total);
}

double sm_csv_read_fps(const char *path, double fallback) {
    double fps = fallback;
    FILE *csv = fopen(path, "r");
    if (!csv) return fps;
    char line[1024];
    int fr1;
    double t1;
    while (fgets(line, sizeof line, csv))
        if (sscanf(line, "%d,%lf", &fr1, &t1) == 2 && fr1 == 1 && t1 > 0) fps = 1.0 / t1;
    fclose(csv);
    return fps;
}
