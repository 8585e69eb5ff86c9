/* diagnostics.csv rows; see csv.h. */
#include <stdio.h>

#include "app/io/csv.h"

int sm_csv_header(char *buf, size_t len) {
    return snprintf(buf, len, "frame,time,steps,min_dt,max_dt,particles,kinetic_energy,elastic_energy,momentum_x,"
                              "momentum_y,momentum_z,max_speed,wall_seconds\n");
}

int sm_csv_row(char *buf, size_t len, int frame, const sm_diagnostics *d, double wall) {
    return snprintf(buf, len, "%d,%.9g,%llu,%.6g,%.6g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.6g,%.4f\n", frame, d->time,
                    (unsigned long long)d->steps, d->min_dt, d->max_dt, d->particles, d->kinetic_energy,
                    d->elastic_energy, d->momentum[0], d->momentum[1], d->momentum[2], d->max_speed, wall);
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
