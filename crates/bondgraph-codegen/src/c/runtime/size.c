/* The change of one parameter that best explains n residuals r of sensitivities s, each
   weighted by w (the inverse of its noise variance), as the runtime's ChangeEstimator
   computes it. A sample forgets the old ones by `forgetting` raised to the information it
   brings over the mean a sample has brought: a stretch that says nothing about the
   parameter forgets nothing. */
static void bgc_change_start(bgc_change *e, int memory)
{
    e->forgetting = 1.0 - 1.0 / (double)memory;
    e->correlation = 1.0;
    e->ss = e->sr = e->rr = e->count = 0.0;
    e->information = e->seen = 0.0;
}

static void bgc_change_push(bgc_change *e, const double *w, const double *r, const double *s, int n)
{
    double ss = 0.0, sr = 0.0, rr = 0.0, exponent, l;
    int i;
    for (i = 0; i < n; i++) {
        ss += w[i] * s[i] * s[i];
        sr += w[i] * s[i] * r[i];
        rr += w[i] * r[i] * r[i];
    }
    if (!(isfinite(ss) && isfinite(sr) && isfinite(rr)))
        return;
    e->seen += 1.0;
    e->information += (ss - e->information) / e->seen;
    if (e->information > 0.0) {
        exponent = ss / e->information;
        if (exponent > 20.0)
            exponent = 20.0;
    } else {
        exponent = 1.0;
    }
    l = pow(e->forgetting, exponent);
    e->ss = l * e->ss + ss;
    e->sr = l * e->sr + sr;
    e->rr = l * e->rr + rr;
    e->count = l * e->count + 1.0;
}

/* The change so far, its 95 % half-width, its misfit and the samples it rests on; 0 until
   the residuals depend on the parameter. */
static int bgc_change_get(const bgc_change *e, int n, double *delta, double *half_width,
                          double *misfit, double *samples)
{
    double left, spread;
    if (e->ss <= 0.0 || e->count < 2.0)
        return 0;
    *delta = -e->sr / e->ss;
    left = e->rr - e->sr * e->sr / e->ss;
    if (!(left >= 0.0))
        left = 0.0;
    spread = left / (e->count - 1.0);
    *half_width = 1.96 * sqrt(spread * e->correlation / e->ss);
    *misfit = sqrt(spread / (double)(n > 1 ? n : 1));
    *samples = e->count;
    return 1;
}

static void bgc_change_reset(bgc_change *e)
{
    e->ss = e->sr = e->rr = e->count = 0.0;
}

/* The step of the difference that gives the sensitivities at `point`. */
static double bgc_size_step(double point)
{
    return point == 0.0 ? 1e-4 : 1e-4 * fabs(point);
}
