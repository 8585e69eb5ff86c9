return { dim = 3, dx = -1, ppc = 0, domain = { min = {1, 1, 1}, max = {0, 0, 0} }, fram = 3,
  materials = { sand = { E = -5, friction_angle = 95, hardening = {35, 9, 0, 10} } },
  objects = { { shape = { type = "cone" } } }, camera = { eye = {0, 0, 0}, target = {0, 1, 0}, up = {0, 1, 0} } }
