#pragma once
// Weight-space interpolation of two models of one network (WiSE-FT, Wortsman et al.,
// CVPR 2022): a fine-tune blended back towards the model it started from keeps more of what
// that model did well while keeping much of the fine-tune's gain on the new data.
#include "handsteady/hsm_format.hpp"

#include <string>

namespace hs {

// (1 - alpha) * from + alpha * to, tensor by tensor, BatchNorm statistics included (they are
// equal when the fine-tune kept them: train.fixed_norm). alpha in [0, 1]. The networks'
// configurations must be equal but for their meta; the result has `to`'s configuration
// (meta: {"blend": {from, to, alpha, from_meta, to_meta}}) and a reference recomputed on
// `to`'s reference input. InputError naming the source and part ("config", "alpha") otherwise.
HsmContents blend_models(const HsmContents& from, const std::string& from_source, const HsmContents& to,
                         const std::string& to_source, double alpha);

}  // namespace hs
