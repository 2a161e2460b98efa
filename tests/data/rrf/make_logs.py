"""Writes the bed-probe logs of a RepRapFirmware and a Marlin delta whose real geometry is not
the one their firmware holds: rrf/bed-probe.log (bed.g's `G30 P.. X.. Y.. Z-99999` lines and
the `G32 bed probe heights:` reply of the last, `S-1`, point) and marlin/g30.log (a host's log
of `G30 X.. Y..` commands and their `Bed X: Y: Z:` replies).

The firmware's kinematics (RepRapFirmware LinearDeltaKinematics, Marlin module/delta.cpp;
formulas only): tower i at R (cos angle_i, sin angle_i), carriage height at the nozzle (x, y, z)
z + sqrt(L_i^2 - (x - t_ix)^2 - (y - t_iy)^2); the carriage's height at its endstop is the
firmware's "homed" carriage height. A touch: the firmware lowers the nozzle at its XY; the
carriages travel IK_fw(x, y, z) - top_fw from their endstops, and the real nozzle (the real
towers, rods and endstop heights, a level bed at 0) is where the three real rods meet. The
probe triggers when the real nozzle is the trigger height above the bed; the firmware reports
its own z there (RRF: z - G31 Z; Marlin: z + M851 Z), rounded to 0.001 mm as they print it.

Run: python3 tests/data/rrf/make_logs.py (from the repository root)
"""
import math


def towers(g):
    return [(g["radius"] * math.cos(math.radians(a)), g["radius"] * math.sin(math.radians(a)))
            for a in g["angles"]]


def ik(g, p):
    return [p[2] + math.sqrt(g["arms"][i] ** 2 - (p[0] - t[0]) ** 2 - (p[1] - t[1]) ** 2)
            for i, t in enumerate(towers(g))]


def top(g, i):
    return g["endstops"][i] + math.sqrt(g["arms"][i] ** 2 - g["radius"] ** 2)


def real_nozzle_z(real, centres_xy, heights):
    """The lowest point at each rod's length from the three carriages (Newton on x, y, z)."""
    x, y, z = 0.0, 0.0, min(heights) - real["arms"][0]
    for _ in range(50):
        f = [(x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - h) ** 2 - real["arms"][i] ** 2
             for i, (c, h) in enumerate(zip(centres_xy, heights))]
        j = [[2 * (x - c[0]), 2 * (y - c[1]), 2 * (z - h)] for c, h in zip(centres_xy, heights)]
        d = solve(j, [-v for v in f])
        x, y, z = x + d[0], y + d[1], z + d[2]
    return z


def solve(a, b):
    m = [row[:] + [v] for row, v in zip(a, b)]
    for c in range(3):
        p = max(range(c, 3), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(3):
            if r != c:
                k = m[r][c] / m[c][c]
                m[r] = [u - k * v for u, v in zip(m[r], m[c])]
    return [m[i][3] / m[i][i] for i in range(3)]


def stopped_z(fw, real, xy, trigger):
    """The firmware's z at which the real nozzle is `trigger` above the bed (secant)."""
    centres = towers(real)

    def gap(z):
        heights = [top(real, i) + h - top(fw, i) for i, h in enumerate(ik(fw, (xy[0], xy[1], z)))]
        return real_nozzle_z(real, centres, heights) - trigger

    a, b = trigger - 1.0, trigger + 1.0
    for _ in range(60):
        fa, fb = gap(a), gap(b)
        if fb == fa:
            break
        a, b = b, b - fb * (b - a) / (fb - fa)
    return b


# RepRapFirmware: config-override.g's values, and the real printer.
RRF_FW = dict(radius=180.5, angles=[210.2, 329.85, 90.0], arms=[360.0] * 3,
              endstops=[301.25 + 0.3, 301.25 - 0.1, 301.25 - 0.2])
RRF_REAL = dict(radius=181.1, angles=[210.45, 329.7, 90.0], arms=[360.0] * 3,
                endstops=[301.87, 300.94, 301.20])
RRF_TRIGGER, RRF_OFFSET = 1.2, (0.0, 15.0)

points = []
for k in range(6):
    a = math.radians(90 + 60 * k)
    points.append((round(120 * math.cos(a), 1), round(120 * math.sin(a), 1)))
for k in range(6):
    a = math.radians(120 + 60 * k)
    points.append((round(60 * math.cos(a), 1), round(60 * math.sin(a), 1)))
points.append((0.0, 0.0))
heights = []
with open("tests/data/rrf/bed-probe.log", "w") as log:
    log.write("; bed.g run from the console (G32), RepRapFirmware 3.5: the points with the probe at\n"
              "; X Y (G31 X0 Y15), the last with S-1 to print the heights instead of calibrating\n")
    log.write("G28\n")
    for n, (x, y) in enumerate(points):
        z = stopped_z(RRF_FW, RRF_REAL, (x - RRF_OFFSET[0], y - RRF_OFFSET[1]), RRF_TRIGGER)
        heights.append(round(z - RRF_TRIGGER, 3))
        tail = " S-1" if n == len(points) - 1 else ""
        log.write(f"G30 P{n} X{x} Y{y} H0 Z-99999{tail}\n")
    mean = sum(heights) / len(heights)
    dev = math.sqrt(sum(h * h for h in heights) / len(heights) - mean * mean)
    log.write("G32 bed probe heights: " + " ".join(f"{h:.3f}" for h in heights)
              + f", mean {mean:.3f}, deviation from mean {dev:.3f}\n")

# Marlin: the M503 report's values, and the real printer.
OFFSET_Z = -0.60
M_H = 288.40
M_FW = dict(radius=95.5, angles=[210.1, 329.75, 90.0], arms=[217.0] * 3,
            endstops=[M_H - OFFSET_Z + 0.42, M_H - OFFSET_Z, M_H - OFFSET_Z + 0.18])
M_REAL = dict(radius=95.95, angles=[210.3, 329.6, 90.0], arms=[217.0] * 3,
              endstops=[289.61, 289.12, 288.83])
with open("tests/data/marlin/g30.log", "w") as log:
    log.write("Send: G28\nRecv: ok\n")
    for k in range(13):
        if k == 12:
            x, y = 0.0, 0.0
        else:
            r = 70.0 if k < 6 else 35.0
            a = math.radians(90 + 60 * k + (30 if k >= 6 else 0))
            x, y = round(r * math.cos(a), 2), round(r * math.sin(a), 2)
        z = stopped_z(M_FW, M_REAL, (x, y), -OFFSET_Z)
        log.write(f"Send: G30 X{x} Y{y}\nRecv: Bed X: {x:.2f} Y: {y:.2f} Z: {z + OFFSET_Z:.3f}\n"
                  f"Recv: X:{x:.2f} Y:{y:.2f} Z:15.00 E:0.00 Count A:30233 B:30233 C:30233\nRecv: ok\n")
