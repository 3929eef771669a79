// The merging of next_measurement()'s mixture components, for the tests'
// plain-R reference merge_components() (tests/testthat/helper-next-measurement.R):
// one pass over the components per bin width
// (the work is in merge_components.h, shared with next_gains_cpp()).
//
// A component falls in the bin of (degrees-of-freedom class, log-scale bin
// sb = floor((log s - min log s) / ws), location bin floor((m - min m) / h)
// with h = wl exp(min log s + sb ws)). While more than `max_components`
// bins are occupied (or more than 10^7 exist), the widths grow by
// sqrt(occupied / max) x 1.1. The merged component has the bin's weight,
// mean, and squared scale (weighted mean square scale plus the locations'
// variance).
#include <Rcpp.h>
#include "merge_components.h"

// [[Rcpp::export]]
Rcpp::List merge_components_cpp(Rcpp::NumericVector w, Rcpp::NumericVector m,
                                Rcpp::NumericVector s, Rcpp::NumericVector ls,
                                Rcpp::IntegerVector nu_class,
                                int n_classes, double width_location, double width_scale,
                                int max_components) {
  griddy::Merged out;
  griddy::merge_components(w.begin(), m.begin(), s.begin(), ls.begin(), nu_class.begin(),
                           w.size(), n_classes, width_location, width_scale, max_components,
                           out);
  return Rcpp::List::create(Rcpp::Named("w") = Rcpp::wrap(out.w),
                            Rcpp::Named("m") = Rcpp::wrap(out.m),
                            Rcpp::Named("s2") = Rcpp::wrap(out.s2),
                            Rcpp::Named("nu_class") = Rcpp::wrap(out.nu_class));
}
