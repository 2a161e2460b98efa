; config-override.g file generated in response to M500 at 2026-11-28 12:03
; This is a system-generated file - do not edit
; Delta parameters
M665 L360.000:360.000:360.000 R180.500 H301.250 B150.0 X0.200 Y-0.150 Z0.000
M666 X0.300 Y-0.100 Z-0.200 A0.00 B0.00
; Heater model parameters
M307 H0 R0.681 K0.511:0.000 D2.54 E1.35 S1.00 B0 V24.1
; Workplace coordinates
G10 L2 P1 X0.00 Y0.00 Z0.00
