#include "service_metrics.hpp"

#include <GLES3/gl31.h>

namespace skylit::live {

StageTimer::~StageTimer() {
  if (cancelled_) return;
  const bool leaves_gl_work = !stage_ || *stage_ == Stage::SunShadow || *stage_ == Stage::Upload || *stage_ == Stage::Blend;
  if (times_.profile && leaves_gl_work) glFinish();
  if (!stage_) return;
  const auto k = static_cast<std::size_t>(*stage_);
  times_.ms[k] += milliseconds_since(start_);
  times_.ran[k] = true;
}

}  // namespace skylit::live
