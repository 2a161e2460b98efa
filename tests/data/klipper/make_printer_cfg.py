"""Writes printer.cfg: a Klipper linear delta (config/example-delta.cfg's geometry) whose
SAVE_CONFIG block holds the seven DELTA_CALIBRATE touches of a "real" printer.

Klipper's conventions (docs/Config_Reference.md, klippy/kinematics/delta.py; formulas only):
tower i at delta_radius * (cos angle_i, sin angle_i); carriage height at nozzle (x, y, z):
z + sqrt(arm_i^2 - dx^2 - dy^2); the endstop's carriage height
position_endstop_i + sqrt(arm_i^2 - delta_radius^2); a stable position is the steps since the
endstop: (endstop height - carriage height) / step distance; heightN is the nozzle's height above
the bed at the touch (the probe's z_offset). The real printer below is within Klipper's six
factors (radius, angle a and b, three endstops): the test recovers it.

Run: python3 tests/data/klipper/make_printer_cfg.py > tests/data/klipper/printer.cfg
"""
import math

REAL = dict(radius=175.15, angles=[210.25, 329.8, 90.0], arms=[333.0] * 3,
            endstops=[297.36, 296.93, 297.10])
STEP = 40.0 / (200 * 16)  # rotation_distance 40, microsteps 16
Z_OFFSET = 1.2
CAL_RADIUS = 50.0


def stable(p, g):
    out = []
    for i in range(3):
        a = math.radians(g["angles"][i])
        tx, ty = g["radius"] * math.cos(a), g["radius"] * math.sin(a)
        arm = g["arms"][i]
        carriage = p[2] + math.sqrt(arm ** 2 - (tx - p[0]) ** 2 - (ty - p[1]) ** 2)
        top = g["endstops"][i] + math.sqrt(arm ** 2 - g["radius"] ** 2)
        out.append((top - carriage) / STEP)
    return out


points = [(0.0, 0.0)]
for i, scatter in enumerate([0.95, 0.90, 0.85, 0.70, 0.75, 0.80]):
    r = math.radians(90.0 + 60.0 * i)
    points.append((math.cos(r) * CAL_RADIUS * scatter, math.sin(r) * CAL_RADIUS * scatter))

print(open(__file__.replace("make_printer_cfg.py", "printer_head.cfg")).read(), end="")
print("#*# <---------------------- SAVE_CONFIG ---------------------->")
print("#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.")
print("#*#")
print("#*# [printer]")
print("#*# delta_radius = 174.750000")
print("#*#")
for name, angle in zip("abc", [210.0, 330.0, 90.0]):
    print(f"#*# [stepper_{name}]")
    print(f"#*# angle = {angle:.6f}")
    print("#*# arm_length = 333.000000")
    print("#*# position_endstop = 297.050000")
    print("#*#")
print("#*# [delta_calibrate]")
for n, (x, y) in enumerate(points):
    s = stable((x, y, Z_OFFSET), REAL)
    print(f"#*# height{n} = {Z_OFFSET}")
    print(f"#*# height{n}_pos = {s[0]:.3f},{s[1]:.3f},{s[2]:.3f}")
