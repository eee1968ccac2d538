/* The worked examples of the RS-M8194H API manual v3.1, chapters 4 and 5 (positions, I/O,
 * FRnet),
 * transcribed from the call printed above each example's register table (the RS line
 * numbers refer to shared/manuals/001_404865bff90dda3e.txt). Each example is one macro
 * program: the manual's frame is the one of the macro form (register 0 "0A xx/0C xx"),
 * so where the manual prints the real-time call RSM_X the macro call RSM_MACRO_X is
 * written, with the printed arguments. tests/data/manual_examples.toml holds the frames. */

#include "RSM8194H.h"

// 4.1.1, RS 2720: printed as the real-time call RSM_SET_LP
RSM_MP_CREATE(hRsm, 1, MP1);  // example RS 2720
RSM_MACRO_SET_LP(hRsm, 1, AXIS_XYZU, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.1.2, RS 2825
RSM_MP_CREATE(hRsm, 1, MP2);  // example RS 2825
RSM_MACRO_GET_LP(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.2.1, RS 2878: printed as the real-time call RSM_SET_EP
RSM_MP_CREATE(hRsm, 1, MP3);  // example RS 2878
RSM_MACRO_SET_EP(hRsm, 1, AXIS_XYZU, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.2.2, RS 2985
RSM_MP_CREATE(hRsm, 1, MP4);  // example RS 2985
RSM_MACRO_GET_EP(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.3.1, RS 3038: printed as the real-time call RSM_ABS_SET_POSITION
RSM_MP_CREATE(hRsm, 1, MP5);  // example RS 3038
RSM_MACRO_ABS_SET_POSITION(hRsm, 1, AXIS_X, 40000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.3.2, RS 3142
RSM_MP_CREATE(hRsm, 1, MP6);  // example RS 3142
RSM_MACRO_ABS_GET_POSITION(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.6.1, RS 3316
RSM_MP_CREATE(hRsm, 1, MP7);  // example RS 3316
RSM_MACRO_GET_DI(hRsm, 1, AXIS_X, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.6.2, RS 3383
RSM_MP_CREATE(hRsm, 1, MP8);  // example RS 3383
RSM_MACRO_GET_DI_ALL(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.7.1, RS 3427
RSM_MP_CREATE(hRsm, 1, MP9);  // example RS 3427
RSM_MACRO_GET_DI_SIGNAL(hRsm, 1, AXIS_X, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.7.2, RS 3494
RSM_MP_CREATE(hRsm, 1, MP10);  // example RS 3494
RSM_MACRO_GET_DI_SIGNAL_ALL(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.8, RS 3564: printed as RSM_MACRO_GET_HOME_STATE, a name found nowhere else; the frame
// code 0C 42 is RSM_MACRO_GET_HOME_SEARCH_STATE (12.3, RS 11601)
RSM_MP_CREATE(hRsm, 1, MP11);  // example RS 3564
RSM_MACRO_GET_HOME_SEARCH_STATE(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.9.1, RS 3627
RSM_MP_CREATE(hRsm, 1, MP12);  // example RS 3627
RSM_MACRO_GET_ERROR(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 4.9.2, RS 3710
RSM_MP_CREATE(hRsm, 1, MP13);  // example RS 3710
RSM_MACRO_GET_ERROR_CODE(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.1.1, RS 4166
RSM_MP_CREATE(hRsm, 1, MP14);  // example RS 4166
RSM_MACRO_FRNET_IN(hRsm, 1, 8);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.1.2, RS 4202
RSM_MP_CREATE(hRsm, 1, MP15);  // example RS 4202
RSM_MACRO_FRNET_READ(hRsm, 1, 8, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.2.1, RS 4379
RSM_MP_CREATE(hRsm, 1, MP16);  // example RS 4379
RSM_MACRO_FRNET_OUT(hRsm, 1, 0, 0x0000FFFF);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.2.1, RS 4394
RSM_MP_CREATE(hRsm, 1, MP17);  // example RS 4394
RSM_MACRO_FRNET_OUT(hRsm, 1, bVAR0, VAR1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.2.2, RS 4437
RSM_MP_CREATE(hRsm, 1, MP18);  // example RS 4437
RSM_MACRO_FRNET_WRITE(hRsm, 1, 1, 1, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 5.3, RS 4602
RSM_MP_CREATE(hRsm, 1, MP19);  // example RS 4602
RSM_MACRO_FRNET_WAIT(hRsm, 1, 8, 1, 1, 1000);
RSM_MACRO_MP_CLOSE(hRsm, 1);
