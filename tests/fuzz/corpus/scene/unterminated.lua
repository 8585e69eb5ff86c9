return {
  dim = 3,
  dx = 0.1,
  gravity = {0, -1e30, 0},
  fps = 1e-300, frames = 1e10,
