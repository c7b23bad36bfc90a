"""The recovery model fitted to measurements (`fit`) and what the fit can say: profile-likelihood intervals, parameters the data do not fix (`profile`), what a fit costs (`fit_cost`)."""
