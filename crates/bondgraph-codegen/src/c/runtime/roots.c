/* A law's value and slope at z, for the root finder. */
typedef void (*bgc_law)(void *context, double z, double *value, double *slope);

/* The law's value alone at z. */
static double bgc_law_value(bgc_law law, void *context, double z)
{
    double value, slope;
    law(context, z, &value, &slope);
    return value;
}

/* Newton's method from z: 1 with the root in *root, 0 when it does not converge. */
static int bgc_newton(bgc_law law, void *context, double z, double *root)
{
    int k;
    for (k = 0; k < 50; k++) {
        double value, slope, step;
        law(context, z, &value, &slope);
        if (value == 0.0) {
            *root = z;
            return 1;
        }
        /* An infinite slope would stop Newton where it stands, as if converged. */
        step = value / slope;
        if (!isfinite(step) || !isfinite(slope))
            return 0;
        z -= step;
        if (fabs(step) <= 4.0 * DBL_EPSILON * fmax(fabs(z), DBL_MIN)) {
            *root = z;
            return isfinite(bgc_law_value(law, context, z));
        }
    }
    return 0;
}

/* Bisects [a, b], where the law changes sign and its value at a is ga. */
static double bgc_bisect(bgc_law law, void *context, double a, double ga, double b)
{
    int k;
    for (k = 0; k < 200; k++) {
        double mid = 0.5 * (a + b), gm;
        if (mid == a || mid == b)
            break;
        gm = bgc_law_value(law, context, mid);
        if (gm == 0.0)
            return mid;
        /* A value that is not a number counts as past the root. */
        if (isfinite(gm) && (gm > 0.0) == (ga > 0.0)) {
            a = mid;
            ga = gm;
        } else {
            b = mid;
        }
    }
    return 0.5 * (a + b);
}

/* A sign change of the law around z, bisected: 1 with the root in *root, 0 if none. */
static int bgc_bracket(bgc_law law, void *context, double z, double *root)
{
    double g0 = bgc_law_value(law, context, z), width;
    int k, side;
    if (g0 == 0.0) {
        *root = z;
        return 1;
    }
    width = 1e-3 * fmax(fabs(z), 1.0);
    for (k = 0; k < 60; k++) {
        for (side = 0; side < 2; side++) {
            double other = side == 0 ? z + width : z - width;
            double value = bgc_law_value(law, context, other);
            if (isfinite(g0) && isfinite(value)
                && (value == 0.0 || (value > 0.0) != (g0 > 0.0))) {
                *root = bgc_bisect(law, context, z, g0, other);
                return 1;
            }
        }
        width *= 2.0;
    }
    return 0;
}

/* The law's root from the last one found: 1 with it in *root, 0 where none is found. */
static int bgc_root_solve(bgc_root_finder *finder, bgc_law law, void *context, double *root)
{
    double start = finder->found ? finder->last : 0.0;
    if (bgc_newton(law, context, start, root) || bgc_bracket(law, context, start, root)) {
        finder->last = *root;
        finder->found = 1;
        return 1;
    }
    finder->failures++;
    return 0;
}
