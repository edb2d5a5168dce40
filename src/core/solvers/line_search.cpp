#include "fem_cloth/core/solvers/line_search.h"

namespace fem_cloth {

const StepBound& LineSearch::bound(IncrementalPotential& potential, const VectorX& x,
                                   const VectorX& dx, bool perDof) {
  if (perDof) {
    bound_.perDof.setOnes(dx.size());
  } else {
    bound_.perDof.resize(0);
  }
  bound_.whole = potential.hasStepBound()
                     ? potential.prepareStep(x, dx, perDof ? &bound_.perDof : nullptr)
                     : 1.0;
  return bound_;
}

void LineSearch::moveToTrial(IncrementalPotential& potential, PotentialIterate& it) {
  it.x.swap(xTrial_);
  it.termGradient.swap(termGradientTrial_);
  potential.gradient(it.x, it.termGradient, it.gradient);
}

bool LineSearch::evaluateFullStep(IncrementalPotential& potential, const PotentialIterate& it,
                                  const VectorX& dx, TermsEvaluation& trial) {
  xTrial_ = it.x + dx;
  trial = potential.evaluateTerms(xTrial_, &termGradientTrial_);
  return trial.inDomain;
}

}  // namespace fem_cloth
