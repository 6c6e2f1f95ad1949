#pragma once
// Brent's one-dimensional minimisation without derivatives (Brent 1973, "localmin"): golden
// section steps safeguarding inverse parabolic interpolation. Used by the object-image
// reflection of Bimber et al. section 7.3 ("Brent's inverse parabolic interpolation with
// bracketing").

#include <cmath>

namespace plx::display {

struct BrentResult {
    double x = 0.0;
    double fx = 0.0;
    int evaluations = 0;
};

// Minimises f on [a, b] (a < b) starting at x0 (the interval's middle when x0 is outside). Stops when the bracket has
// shrunk to about xTol around the minimum, when f drops to fTarget or below (the caller knows
// the minimum value is 0), or after maxEvaluations.
template <class F>
BrentResult brentMinimize(F&& f, double a, double b, double x0, double xTol, double fTarget,
                          int maxEvaluations) {
    constexpr double kGolden = 0.3819660112501051;  // (3 - sqrt(5)) / 2
    constexpr double kEps = 1.5e-8;                 // about sqrt(double epsilon)
    double x = (x0 > a && x0 < b) ? x0 : 0.5 * (a + b);
    double w = x, v = x;
    double fx = f(x);
    double fw = fx, fv = fx;
    double d = 0.0, e = 0.0;
    int evaluations = 1;
    while (evaluations < maxEvaluations && fx > fTarget) {
        double m = 0.5 * (a + b);
        double tol1 = kEps * std::fabs(x) + xTol;
        double tol2 = 2.0 * tol1;
        if (std::fabs(x - m) <= tol2 - 0.5 * (b - a)) break;
        bool golden = true;
        if (std::fabs(e) > tol1) {
            // Parabola through (v, fv), (w, fw), (x, fx).
            double r = (x - w) * (fx - fv);
            double q = (x - v) * (fx - fw);
            double p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if (q > 0.0) p = -p;
            else q = -q;
            double eOld = e;
            e = d;
            if (std::fabs(p) < std::fabs(0.5 * q * eOld) && p > q * (a - x) && p < q * (b - x)) {
                d = p / q;
                double u = x + d;
                if (u - a < tol2 || b - u < tol2) d = x < m ? tol1 : -tol1;
                golden = false;
            }
        }
        if (golden) {
            e = (x < m ? b : a) - x;
            d = kGolden * e;
        }
        double u = x + (std::fabs(d) >= tol1 ? d : (d > 0.0 ? tol1 : -tol1));
        double fu = f(u);
        ++evaluations;
        if (fu <= fx) {
            if (u < x) b = x;
            else a = x;
            v = w, fv = fw;
            w = x, fw = fx;
            x = u, fx = fu;
        } else {
            if (u < x) a = u;
            else b = u;
            if (fu <= fw || w == x) {
                v = w, fv = fw;
                w = u, fw = fu;
            } else if (fu <= fv || v == x || v == w) {
                v = u, fv = fu;
            }
        }
    }
    return {x, fx, evaluations};
}

}  // namespace plx::display
