/* -1, 0 or 1 as the sign of x (0 where x is not a number). */
static double bgc_sign(double x)
{
    return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
}
