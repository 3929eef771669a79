// What the OpenMP runtime allows, for griddy_threads() (R/threads.R), which
// decides how many threads the compiled code uses. Without OpenMP (a
// compiler that lacks it) the package runs on one thread.
#include <Rcpp.h>
#ifdef _OPENMP
#include <omp.h>
#endif

// The logical processors, the runtime's thread limit (OMP_THREAD_LIMIT) and
// its default team size (OMP_NUM_THREADS); 1, 1, 1 without OpenMP.
// [[Rcpp::export]]
Rcpp::IntegerVector omp_limits_cpp() {
#ifdef _OPENMP
  return Rcpp::IntegerVector::create(omp_get_num_procs(), omp_get_thread_limit(),
                                     omp_get_max_threads());
#else
  return Rcpp::IntegerVector::create(1, 1, 1);
#endif
}
