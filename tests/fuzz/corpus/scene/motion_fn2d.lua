local n = params.n or 1
return { dim = 2, dx = 0.1, frames = 1, domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { friction_angle = 33 } },
  objects = { { shape = { type = "box", center = {0.5, 0.2}, half_extent = {0.1 * n, 0.1} } } },
  colliders = { { shape = { type = "halfspace", point = {0, 0.05}, normal = {0, 1} }, mode = "sticky" },
    { shape = { type = "sphere", center = {0, 0}, radius = 0.05 }, mode = "slip", friction = 0.3,
      motion = function(t) return {0.5, 0.6 - t}, axis_angle(0, 0, 1, 10 * t) end } } }
