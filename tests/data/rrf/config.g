; Configuration file for a Duet 3 Mini 5+ linear delta (written after the RepRapFirmware
; configuration tool's delta template and the G-code documentation of M665, M666, M92, G31)
; executed by the firmware on start-up

; General preferences
G90                                          ; send absolute coordinates...
M83                                          ; ...but relative extruder moves
M550 P"Legwise test delta"                   ; set printer name
M665 R180 L360 B150 H300                     ; set delta radius, diagonal rod length, printable radius and homed height
M666 X0 Y0 Z0                                ; put your endstop adjustments here, or let auto calibration find them

; Drives
M569 P0.0 S1                                 ; physical drive 0.0 goes forwards
M569 P0.1 S1                                 ; physical drive 0.1 goes forwards
M569 P0.2 S1                                 ; physical drive 0.2 goes forwards
M584 X0.0 Y0.1 Z0.2 E0.3                     ; set drive mapping
M350 X16 Y16 Z16 E16 I1                      ; configure microstepping with interpolation
M92 X80.00 Y80.00 Z80.00 E420.00             ; set steps per mm
M566 X1200.00 Y1200.00 Z1200.00 E1200.00     ; set maximum instantaneous speed changes (mm/min)
M203 X18000.00 Y18000.00 Z18000.00 E1200.00  ; set maximum speeds (mm/min)
M906 X1000 Y1000 Z1000 E800 I30              ; set motor currents (mA) and motor idle factor in per cent

; Endstops
M574 X2 S1 P"io0.in"                         ; configure switch-type (e.g. microswitch) endstop for high end on X
M574 Y2 S1 P"io1.in"                         ; configure switch-type (e.g. microswitch) endstop for high end on Y
M574 Z2 S1 P"io2.in"                         ; configure switch-type (e.g. microswitch) endstop for high end on Z

; Z-Probe
M558 P8 C"io3.in" H5 F120 T6000              ; set Z probe type to unmodulated and the dive height + speeds
G31 P500 X0 Y15 Z1.2                         ; set Z probe trigger value, offset and trigger height
M557 R140 S20                                ; define mesh grid

; Miscellaneous
M501                                         ; load saved parameters from non-volatile memory (config-override.g)
