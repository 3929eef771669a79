#ifndef GRIDDY_QUADRATIC_FORMS_H
#define GRIDDY_QUADRATIC_FORMS_H

#include <RcppArmadillo.h>

namespace griddy {
void ar1_innovations(const arma::mat& E, const arma::vec& phi,
                     const arma::vec& inv_sd, arma::mat& W);
}

#endif
