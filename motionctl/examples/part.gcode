%
(part.gcode: a pocket outline in mm, a relative step pattern, and an inch section)
N10 G21 G90            ; millimetres, absolute
N20 G0 X20 Y20
N30 M3 S12000          ; spindle on (speed is ignored)
N40 G1 Z-1.5 F200
N50 G1 X60 F1500
n60 y50
N70 x20 (lowercase and a comment mid-block) y 50
N80 Y20
N90 G91                ; relative steps
N100 G1 X5 Y5
N110 X5 Y5
N120 X-10 Y-10
N130 G90 G0 Z0
N140 M0                ; check the part, then resume
N150 G20               ; inches from here
N160 G1 X1.5 Y1 F40    ; X 38.1 mm, Y 25.4 mm at 1016 mm/min
N170 G21 G0 X10 Y10
N180 M5
N190 M30
%
