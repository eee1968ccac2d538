/* The worked examples of the RS-M8194H API manual v3.1, chapter 3 (axis settings),
 * transcribed from the call printed above each example's register table (the RS line
 * numbers refer to shared/manuals/001_404865bff90dda3e.txt). Each example is one macro
 * program: the manual's frame is the one of the macro form (register 0 "0A xx/0C xx"),
 * so where the manual prints the real-time call RSM_X the macro call RSM_MACRO_X is
 * written, with the printed arguments. tests/data/manual_examples.toml holds the frames. */

#include "RSM8194H.h"

// 3.3, RS 1107: printed as the real-time call RSM_SET_PULSE_MODE
RSM_MP_CREATE(hRsm, 1, MP1);  // example RS 1107
RSM_MACRO_SET_PULSE_MODE(hRsm, 1, AXIS_XYZ, 2);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.4, RS 1172: printed as the real-time call RSM_SET_MAX_V with 20000L, a slip: the frame
// (00 03 0D 40) and both comments (200 KPPS, 200000/8000) say 200000
RSM_MP_CREATE(hRsm, 1, MP2);  // example RS 1172
RSM_MACRO_SET_MAX_V(hRsm, 1, AXIS_XY, 200000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.5, RS 1227: printed as the real-time call RSM_SET_HLMT
RSM_MP_CREATE(hRsm, 1, MP3);  // example RS 1227
RSM_MACRO_SET_HLMT(hRsm, 1, AXIS_XYZU, 0, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.6, RS 1277: printed as the real-time call RSM_LIMITSTOP_MODE
RSM_MP_CREATE(hRsm, 1, MP4);  // example RS 1277
RSM_MACRO_LIMITSTOP_MODE(hRsm, 1, AXIS_X, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.7, RS 1329: printed as the real-time call RSM_SET_NHOME
RSM_MP_CREATE(hRsm, 1, MP5);  // example RS 1329
RSM_MACRO_SET_NHOME(hRsm, 1, AXIS_XY, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.8, RS 1374: printed as the real-time call RSM_SET_HOME_EDGE
RSM_MP_CREATE(hRsm, 1, MP6);  // example RS 1374
RSM_MACRO_SET_HOME_EDGE(hRsm, 1, AXIS_XYZU, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.9.1, RS 1424: printed as the real-time call RSM_SET_SLMT
RSM_MP_CREATE(hRsm, 1, MP7);  // example RS 1424
RSM_MACRO_SET_SLMT(hRsm, 1, AXIS_XYZU, 20000, -3000, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.9.2, RS 1475: printed as the real-time call RSM_CLEAR_SLMT
RSM_MP_CREATE(hRsm, 1, MP8);  // example RS 1475
RSM_MACRO_CLEAR_SLMT(hRsm, 1, AXIS_XYZU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.10, RS 1566: printed as the real-time call RSM_SET_ENCODER
RSM_MP_CREATE(hRsm, 1, MP9);  // example RS 1566
RSM_MACRO_SET_ENCODER(hRsm, 1, AXIS_XYZU, 0, 0, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.11.1, RS 1616: printed as the real-time call RSM_SERVO_ON
RSM_MP_CREATE(hRsm, 1, MP10);  // example RS 1616
RSM_MACRO_SERVO_ON(hRsm, 1, AXIS_XYZU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.11.2, RS 1663: printed as the real-time call RSM_SERVO_OFF
RSM_MP_CREATE(hRsm, 1, MP11);  // example RS 1663
RSM_MACRO_SERVO_OFF(hRsm, 1, AXIS_XYZU);  //disables all drivers on module 1.
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.12, RS 1707: printed as the real-time call RSM_SET_ALARM
RSM_MP_CREATE(hRsm, 1, MP12);  // example RS 1707
RSM_MACRO_SET_ALARM(hRsm, 1, AXIS_ZU, 1, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.13, RS 1763: printed as the real-time call RSM_SET_INPOS
RSM_MP_CREATE(hRsm, 1, MP13);  // example RS 1763
RSM_MACRO_SET_INPOS(hRsm, 1, AXIS_X, 1, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.14, RS 1839: printed as the real-time call RSM_SET_FILTER
RSM_MP_CREATE(hRsm, 1, MP14);  // example RS 1839
RSM_MACRO_SET_FILTER(hRsm, 1, AXIS_XYZU, 21, 3);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.15.1, RS 1900: printed as the real-time call RSM_VRING_ENABLE
RSM_MP_CREATE(hRsm, 1, MP15);  // example RS 1900
RSM_MACRO_VRING_ENABLE(hRsm, 1, AXIS_X, 9999);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.15.2, RS 1961: printed as the real-time call RSM_VRING_DISABLE
RSM_MP_CREATE(hRsm, 1, MP16);  // example RS 1961
RSM_MACRO_VRING_DISABLE(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.16.1, RS 2007: printed as the real-time call RSM_AVTRI_ENABLE
RSM_MP_CREATE(hRsm, 1, MP17);  // example RS 2007
RSM_MACRO_AVTRI_ENABLE(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 3.16.2, RS 2051: printed as the real-time call RSM_AVTRI_DISABLE
RSM_MP_CREATE(hRsm, 1, MP18);  // example RS 2051
RSM_MACRO_AVTRI_DISABLE(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);
