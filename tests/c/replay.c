/* Runs a model's C residual generator (`bgc MODEL --emit c -o m.c`) over a CSV record and
   prints what `bgc residuals` prints of it: per estimate t, the residuals, their thresholds,
   the alarms and the candidates.

   cc -std=c99 -DBGC_HEADER='"m.h"' -DBGC_PREFIX=model -DBGC_UPPER=MODEL m.c replay.c -lm
   replay RECORD.csv STEP WINDOW [--debounce N] [--adaptive] [--integration N|start]
          [--threshold K=LEVEL]... */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include BGC_HEADER

#define JOIN2(a, b) a##_##b
#define JOIN(a, b) JOIN2(a, b)
#define F(name) JOIN(BGC_PREFIX, name)
#define M(name) JOIN(BGC_UPPER, name)

#define LINE 65536
#define COLUMNS 1024

static F(generator) generator;

static int fail(const char *what, const char *detail)
{
    fprintf(stderr, "replay: %s%s\n", what, detail);
    return 1;
}

/* Splits `line` at commas in place; returns how many cells. */
static int split(char *line, char **cells)
{
    int n = 0;
    char *p = line;
    line[strcspn(line, "\r\n")] = '\0';
    cells[n++] = p;
    while ((p = strchr(p, ',')) != NULL && n < COLUMNS) {
        *p++ = '\0';
        cells[n++] = p;
    }
    return n;
}

static void number(double x)
{
    if (x == x)
        printf(",%.17g", x);
    else
        printf(",");
}

int main(int argc, char **argv)
{
    static char line[LINE];
    char *cells[COLUMNS];
    int column[M(RAW) > 0 ? M(RAW) : 1], time = -1, n, k, j, status, degree;
    double raw[M(RAW) > 0 ? M(RAW) : 1];
    F(output) out;
    FILE *record;
    if (argc < 4)
        return fail("usage: replay RECORD.csv STEP WINDOW [options]", "");
    degree = M(ORDER) > 3 ? M(ORDER) : 3;
    status = F(init)(&generator, &F(default_params), atof(argv[2]), atoi(argv[3]), degree);
    if (status != BGC_OK)
        return fail("init: ", F(status_text)(status));
    for (k = 4; k < argc; k++) {
        if (strcmp(argv[k], "--adaptive") == 0) {
            F(set_adaptive)(&generator, 1);
        } else if (strcmp(argv[k], "--debounce") == 0 && k + 1 < argc) {
            F(set_debounce)(&generator, (unsigned)atoi(argv[++k]));
        } else if (strcmp(argv[k], "--integration") == 0 && k + 1 < argc) {
            if (strcmp(argv[++k], "start") == 0)
                F(integrate_from_start)(&generator);
            else if (F(set_integration_window)(&generator, atoi(argv[k])) != BGC_OK)
                return fail("bad integration window ", argv[k]);
        } else if (strcmp(argv[k], "--threshold") == 0 && k + 1 < argc) {
            const char *arg = argv[++k], *eq = strchr(arg, '=');
            int found = 0;
            for (j = 0; eq != NULL && j < M(RESIDUALS); j++) {
                const char *name = F(residual_names)[j];
                if (strlen(name) == (size_t)(eq - arg) && strncmp(name, arg, (size_t)(eq - arg)) == 0) {
                    F(set_threshold)(&generator, j, atof(eq + 1));
                    found = 1;
                }
            }
            if (!found)
                return fail("no residual for ", arg);
        } else {
            return fail("unknown option ", argv[k]);
        }
    }
    record = fopen(argv[1], "r");
    if (record == NULL || fgets(line, LINE, record) == NULL)
        return fail("cannot read ", argv[1]);
    n = split(line, cells);
    for (j = 0; j < M(RAW); j++)
        column[j] = -1;
    for (k = 0; k < n; k++) {
        if (strcmp(cells[k], "t") == 0)
            time = k;
        for (j = 0; j < M(RAW); j++)
            if (strcmp(cells[k], F(raw_names)[j]) == 0)
                column[j] = k;
    }
    if (time < 0)
        return fail("no column t in ", argv[1]);
    for (j = 0; j < M(RAW); j++)
        if (column[j] < 0)
            return fail("no column for ", F(raw_names)[j]);
    printf("t");
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",%s", F(residual_names)[j]);
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",threshold_%s", F(residual_names)[j]);
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",alarm_%s", F(residual_names)[j]);
    printf(",candidates\n");
    while (fgets(line, LINE, record) != NULL) {
        int alarms[M(RESIDUALS) > 0 ? M(RESIDUALS) : 1], found[M(COMPONENTS) > 0 ? M(COMPONENTS) : 1], count;
        n = split(line, cells);
        for (j = 0; j < M(RAW); j++)
            raw[j] = column[j] < n ? atof(cells[column[j]]) : NAN;
        if (!F(push)(&generator, atof(cells[time]), raw, &out))
            continue;
        printf("%.17g", out.at);
        for (j = 0; j < M(RESIDUALS); j++)
            number(out.residuals[j]);
        for (j = 0; j < M(RESIDUALS); j++)
            number(out.thresholds[j]);
        for (j = 0; j < M(RESIDUALS); j++) {
            printf(",%d", out.alarms[j]);
            alarms[j] = out.alarms[j];
        }
        count = F(candidates)(alarms, found);
        printf(",");
        for (j = 0; j < count; j++)
            printf("%s%s", j > 0 ? " " : "", F(component_names)[found[j]]);
        printf("\n");
    }
    fclose(record);
    return 0;
}
