/* The next value of a running trapezoidal integral. */
static double bgc_trapezoid_push(bgc_trapezoid *z, double t, double x)
{
    if (z->started)
        z->sum += 0.5 * (t - z->t) * (x + z->x);
    z->t = t;
    z->x = x;
    z->started = 1;
    return z->sum;
}
