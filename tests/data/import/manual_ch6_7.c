/* The worked examples of the RS-M8194H API manual v3.1, chapters 6 and 7 (home search,
 * motion, interpolation, synchronisation, stops),
 * transcribed from the call printed above each example's register table (the RS line
 * numbers refer to shared/manuals/001_404865bff90dda3e.txt). Each example is one macro
 * program: the manual's frame is the one of the macro form (register 0 "0A xx/0C xx"),
 * so where the manual prints the real-time call RSM_X the macro call RSM_MACRO_X is
 * written, with the printed arguments. tests/data/manual_examples.toml holds the frames. */

#include "RSM8194H.h"

// 6.1, RS 4739: printed as the real-time call RSM_SET_HV
RSM_MP_CREATE(hRsm, 1, MP1);  // example RS 4739
RSM_MACRO_SET_HV(hRsm, 1, AXIS_X, 500);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 6.2, RS 4785: printed as the real-time call RSM_HOME_LIMIT
RSM_MP_CREATE(hRsm, 1, MP2);  // example RS 4785
RSM_MACRO_HOME_LIMIT(hRsm, 1, AXIS_X, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 6.3, RS 4842: printed as the real-time call RSM_SET_HOME_MODE
RSM_MP_CREATE(hRsm, 1, MP3);  // example RS 4842
RSM_MACRO_SET_HOME_MODE(hRsm, 1, 0x1, 2, 2, 1, 1, 3500);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 6.4, RS 4891: printed as the real-time call RSM_HOME_START
RSM_MP_CREATE(hRsm, 1, MP4);  // example RS 4891
RSM_MACRO_HOME_START(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.1, RS 4951: printed as the real-time call RSM_NORMAL_SPEED
RSM_MP_CREATE(hRsm, 1, MP5);  // example RS 4951
RSM_MACRO_NORMAL_SPEED(hRsm, 1, AXIS_XYZU, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.2, RS 5075: printed as the real-time call RSM_SET_SV
RSM_MP_CREATE(hRsm, 1, MP6);  // example RS 5075
RSM_MACRO_SET_SV(hRsm, 1, AXIS_X, 1000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.3, RS 5123: printed as the real-time call RSM_SET_V
RSM_MP_CREATE(hRsm, 1, MP7);  // example RS 5123
RSM_MACRO_SET_V(hRsm, 1, AXIS_X, 120000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.4, RS 5172: printed as the real-time call RSM_SET_A
RSM_MP_CREATE(hRsm, 1, MP8);  // example RS 5172
RSM_MACRO_SET_A(hRsm, 1, AXIS_X, 100000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.5, RS 5223: printed as the real-time call RSM_SET_D
RSM_MP_CREATE(hRsm, 1, MP9);  // example RS 5223
RSM_MACRO_SET_D(hRsm, 1, AXIS_X, 100000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.6, RS 5271: printed as the real-time call RSM_SET_K
RSM_MP_CREATE(hRsm, 1, MP10);  // example RS 5271
RSM_MACRO_SET_K(hRsm, 1, AXIS_X, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.7, RS 5322: printed as the real-time call RSM_SET_L
RSM_MP_CREATE(hRsm, 1, MP11);  // example RS 5322
RSM_MACRO_SET_L(hRsm, 1, AXIS_X, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.8, RS 5378: printed as the real-time call RSM_SET_AO
RSM_MP_CREATE(hRsm, 1, MP12);  // example RS 5378
RSM_MACRO_SET_AO(hRsm, 1, AXIS_X, 200);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.9, RS 5433: printed as the real-time call RSM_FIXED_MOVE
RSM_MP_CREATE(hRsm, 1, MP13);  // example RS 5433
RSM_MACRO_FIXED_MOVE(hRsm, SlaveAddr, AXIS_XYZU, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.10, RS 5503: printed as the real-time call RSM_SET_PULSE
RSM_MP_CREATE(hRsm, 1, MP14);  // example RS 5503
RSM_MACRO_SET_PULSE(hRsm, SlaveAddr, AXIS_XYZU, 9000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.11, RS 5578: printed as the real-time call RSM_ABS_FIXED_MOVE
RSM_MP_CREATE(hRsm, 1, MP15);  // example RS 5578
RSM_ABS_MACRO_FIXED_MOVE(hRsm, SlaveAddr, AXIS_XYZU, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.1.12, RS 5652: printed as the real-time call RSM_CONTINUE_MOVE
RSM_MP_CREATE(hRsm, 1, MP16);  // example RS 5652
RSM_MACRO_CONTINUE_MOVE(hRsm, SlaveAddr, AXIS_XYZU, 1000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.1, RS 5724: printed as the real-time call RSM_AXIS_ASSIGN
RSM_MP_CREATE(hRsm, 1, MP17);  // example RS 5724
RSM_MACRO_AXIS_ASSIGN(hRsm, 1, AXIS_X, AXIS_Y, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.2, RS 5776: printed as the real-time call RSM_VECTOR_SPEED
RSM_MP_CREATE(hRsm, 1, MP18);  // example RS 5776
RSM_MACRO_VECTOR_SPEED(hRsm, SlaveAddr, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.3, RS 6090: printed as the real-time call RSM_SET_VSV
RSM_MP_CREATE(hRsm, 1, MP19);  // example RS 6090
RSM_MACRO_SET_VSV(hRsm, 1, 1000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.4, RS 6137: printed as the real-time call RSM_SET_VV with 12000L, a slip: the frame
// (00 01 D4 C0) and the comment say 120000
RSM_MP_CREATE(hRsm, 1, MP20);  // example RS 6137
RSM_MACRO_SET_VV(hRsm, 1, 120000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.5, RS 6185: printed as the real-time call RSM_SET_VA
RSM_MP_CREATE(hRsm, 1, MP21);  // example RS 6185
RSM_MACRO_SET_VA(hRsm, 1, 100000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.6, RS 6233: printed as the real-time call RSM_SET_VD
RSM_MP_CREATE(hRsm, 1, MP22);  // example RS 6233
RSM_MACRO_SET_VD(hRsm, 1, 100000L);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.7, RS 6287: printed as the real-time call RSM_SET_VK
RSM_MP_CREATE(hRsm, 1, MP23);  // example RS 6287
RSM_MACRO_SET_VK(hRsm, 1, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.8, RS 6341: printed as the real-time call RSM_SET_VL
RSM_MP_CREATE(hRsm, 1, MP24);  // example RS 6341
RSM_MACRO_SET_VL(hRsm, 1, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.9, RS 6394: printed as the real-time call RSM_SET_VAO
RSM_MP_CREATE(hRsm, 1, MP25);  // example RS 6394
RSM_MACRO_SET_VAO(hRsm, 1, 200);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.10, RS 6444: printed as the real-time call RSM_LINE_2D
RSM_MP_CREATE(hRsm, 1, MP26);  // example RS 6444
RSM_MACRO_LINE_2D(hRsm, 1, 12000, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.11, RS 6498: printed as the real-time call RSM_ABS_LINE_2D
RSM_MP_CREATE(hRsm, 1, MP27);  // example RS 6498
RSM_ABS_MACRO_LINE_2D(hRsm, 1, 12000, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.12, RS 6553: printed as the real-time call RSM_LINE_3D
RSM_MP_CREATE(hRsm, 1, MP28);  // example RS 6553
RSM_MACRO_LINE_3D(hRsm, 1, 10000, 10000, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.13, RS 6612: printed as the real-time call RSM_ABS_LINE_3D
RSM_MP_CREATE(hRsm, 1, MP29);  // example RS 6612
RSM_ABS_MACRO_LINE_3D(hRsm, 1, 10000, 10000, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.14, RS 6668: printed as the real-time call RSM_ARC_CW
RSM_MP_CREATE(hRsm, 1, MP30);  // example RS 6668
RSM_MACRO_ARC_CW(hRsm, 1, -5000, -5000, -10000, -10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.15, RS 6729: printed as the real-time call RSM_ARC_CCW
RSM_MP_CREATE(hRsm, 1, MP31);  // example RS 6729
RSM_MACRO_ARC_CCW(hRsm, 1, -5000, -5000, -10000, -10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.16, RS 6792: printed as the real-time call RSM_ABS_ARC_CW
RSM_MP_CREATE(hRsm, 1, MP32);  // example RS 6792
RSM_ABS_MACRO_ARC_CW(hRsm, 1, -5000, -5000, -10000, -10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.17, RS 6855: printed as RSM_ARC_CCW, the relative arc; the frame code 0A FA/0C FA is
// the absolute one
RSM_MP_CREATE(hRsm, 1, MP33);  // example RS 6855
RSM_ABS_MACRO_ARC_CCW(hRsm, 1, -5000, -5000, -10000, -10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.18, RS 6915: printed as the real-time call RSM_CIRCLE_CW
RSM_MP_CREATE(hRsm, 1, MP34);  // example RS 6915
RSM_MACRO_CIRCLE_CW(hRsm, 1, 0, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.2.19, RS 6967: printed as the real-time call RSM_CIRCLE_CCW
RSM_MP_CREATE(hRsm, 1, MP35);  // example RS 6967
RSM_MACRO_CIRCLE_CCW(hRsm, 1, 0, 10000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.1, RS 7104: printed as the real-time call RSM_SYNC_ACTION
RSM_MP_CREATE(hRsm, 1, MP36);  // example RS 7104
RSM_MACRO_SYNC_ACTION(hRsm, SlaveAddr, AXIS_U, AXIS_U, 0X00000040, 0, 2, 4, 0, 0, 0, 0, 0, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.2, RS 7345: printed as the real-time call RSM_CLEAR_SYNC_ACTION
RSM_MP_CREATE(hRsm, 1, MP37);  // example RS 7345
RSM_MACRO_CLEAR_SYNC_ACTION(hRsm, 1, AXIS_X);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.3, RS 7404: printed as the real-time call RSM_SET_ACTIVATION_FACTORS
RSM_MP_CREATE(hRsm, 1, MP38);  // example RS 7404
RSM_MACRO_SET_ACTIVATION_FACTORS(hRsm, 1, AXIS_X, 0X00000001);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.4, RS 7451: printed as the real-time call RSM_SET_ACTIVATION_AXIS
RSM_MP_CREATE(hRsm, 1, MP39);  // example RS 7451
RSM_MACRO_SET_ACTIVATION_AXIS(hRsm, 1, AXIS_X, AXIS_Y);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.5, RS 7576: printed as the real-time call RSM_SET_ACTION
RSM_MP_CREATE(hRsm, 1, MP40);  // example RS 7576
RSM_MACRO_SET_ACTION(hRsm, 1, AXIS_Y, 0, 2, 4, 0, 0, 0, 0, 0, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.6, RS 7694: printed as the real-time call RSM_SET_COMPARE
RSM_MP_CREATE(hRsm, 1, MP41);  // example RS 7694
RSM_MACRO_SET_COMPARE(hRsm, SlaveAddr, AXIS_U, 0, 1, 5000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.7, RS 7786
RSM_MP_CREATE(hRsm, 1, MP42);  // example RS 7786
RSM_MACRO_GET_LATCH(hRsm, 1, AXIS_Y);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.8, RS 7834: printed as the real-time call RSM_SET_PRESET
RSM_MP_CREATE(hRsm, 1, MP43);  // example RS 7834
RSM_MACRO_SET_PRESET(hRsm, SlaveAddr, AXIS_U, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.9, RS 7883: printed as the real-time call RSM_SET_OUT
RSM_MP_CREATE(hRsm, 1, MP44);  // example RS 7883
RSM_MACRO_SET_OUT(hRsm, 1, AXIS_U, 1, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.10, RS 7929: printed as the real-time call RSM_ENABLE_INT
RSM_MP_CREATE(hRsm, 1, MP45);  // example RS 7929
RSM_MACRO_ENABLE_INT(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.11, RS 7971: printed as the real-time call RSM_DISABLE_INT
RSM_MP_CREATE(hRsm, 1, MP46);  // example RS 7971
RSM_MACRO_DISABLE_INT(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.12, RS 8037: printed as the real-time call RSM_INTFACTOR_ENABLE
RSM_MP_CREATE(hRsm, 1, MP47);  // example RS 8037
RSM_MACRO_INTFACTOR_ENABLE(hRsm, 1, AXIS_X, 4, ISR1);  //When the position counter of x axis exceeds C+, then call ISR1.
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.3.13, RS 8158: printed as the real-time call RSM_INTFACTOR_DISABLE
RSM_MP_CREATE(hRsm, 1, MP48);  // example RS 8158
RSM_MACRO_INTFACTOR_DISABLE(hRsm, 1, AXIS_XYZU, 4);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.1, RS 8228: printed as the real-time call RSM_RECTANGLE
RSM_MP_CREATE(hRsm, 1, MP49);  // example RS 8228
RSM_MACRO_RECTANGLE(hRsm, 1, AXIS_X, AXIS_Y, 1, 0, 0, 20000, 10000, 1000, 1000, 10000, 5000, 5000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.2, RS 8297: printed as the real-time call RSM_LINE_2D_INITIAL
RSM_MP_CREATE(hRsm, 1, MP50);  // example RS 8297
RSM_MACRO_LINE_2D_INITIAL(hRsm, 1, AXIS_X, AXIS_Y, 300, 18000, 500000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.3, RS 8353: printed as the real-time call RSM_LINE_2D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP51);  // example RS 8353
RSM_MACRO_LINE_2D_CONTINUE(hRsm, 1, 0, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.4, RS 8428: printed as the real-time call RSM_ABS_LINE_2D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP52);  // example RS 8428
RSM_ABS_MACRO_LINE_2D_CONTINUE(hRsm, 1, 0, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.5, RS 8505: printed as the real-time call RSM_LINE_3D_INITIAL
RSM_MP_CREATE(hRsm, 1, MP53);  // example RS 8505
RSM_MACRO_LINE_3D_INITIAL(hRsm, 1, AXIS_X, AXIS_Y, AXIS_Z, 300, 18000, 500000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.6, RS 8565: printed as the real-time call RSM_LINE_3D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP54);  // example RS 8565
RSM_MACRO_LINE_3D_CONTINUE(hRsm, 1, 0, 100, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.7, RS 8643: printed as the real-time call RSM_ABS_LINE_3D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP55);  // example RS 8643
RSM_ABS_MACRO_LINE_3D_CONTINUE(hRsm, 1, 0, 100, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.8, RS 8722: printed as the real-time call RSM_MIX_2D_INITIAL
RSM_MP_CREATE(hRsm, 1, MP56);  // example RS 8722
RSM_MACRO_MIX_2D_INITIAL(hRsm, 1, 1, 2, 0, 300, 18000, 500000);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.9, RS 8780: printed as the real-time call RSM_MIX_2D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP57);  // example RS 8780
RSM_MACRO_MIX_2D_CONTINUE(hRsm, 1, 0, 1, 0, 0, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.10, RS 8837: printed as the real-time call RSM_ABS_MIX_2D_CONTINUE
RSM_MP_CREATE(hRsm, 1, MP58);  // example RS 8837
RSM_ABS_MACRO_MIX_2D_CONTINUE(hRsm, 1, 0, 1, 0, 0, 100, 100);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.4.11, RS 8898: printed as the real-time call RSM_HELIX_3D
RSM_MP_CREATE(hRsm, 1, MP59);  // example RS 8898
RSM_MACRO_HELIX_3D(hRsm, 1, AXIS_Y, AXIS_Z, AXIS_U, 1, 50000, 0, 25000, 50, 3600);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.1, RS 9154: printed as the real-time call RSM_DRV_HOLD
RSM_MP_CREATE(hRsm, 1, MP60);  // example RS 9154
RSM_MACRO_DRV_HOLD(hRsm, 1, AXIS_XYU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.2, RS 9236: printed as the real-time call RSM_DRV_START
RSM_MP_CREATE(hRsm, 1, MP61);  // example RS 9236
RSM_MACRO_DRV_START(hRsm, 1, AXIS_XYU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.3, RS 9318: printed as the real-time call RSM_STOP_SLOWLY
RSM_MP_CREATE(hRsm, 1, MP62);  // example RS 9318
RSM_MACRO_STOP_SLOWLY(hRsm, 1, AXIS_XY);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.4, RS 9363: printed as the real-time call RSM_STOP_SUDDENLY
RSM_MP_CREATE(hRsm, 1, MP63);  // example RS 9363
RSM_MACRO_STOP_SUDDENLY(hRsm, 1, AXIS_ZU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.5, RS 9406: printed as the real-time call RSM_VSTOP_SLOWLY
RSM_MP_CREATE(hRsm, 1, MP64);  // example RS 9406
RSM_MACRO_VSTOP_SLOWLY(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.6, RS 9448: printed as the real-time call RSM_VSTOP_SUDDENLY
RSM_MP_CREATE(hRsm, 1, MP65);  // example RS 9448
RSM_MACRO_VSTOP_SUDDENLY(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.7, RS 9490: printed as the real-time call RSM_CLEAR_STOP
RSM_MP_CREATE(hRsm, 1, MP66);  // example RS 9490
RSM_MACRO_CLEAR_STOP(hRsm, 1, AXIS_ZU);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.8, RS 9533: printed as the real-time call RSM_CLEAR_VSTOP
RSM_MP_CREATE(hRsm, 1, MP67);  // example RS 9533
RSM_MACRO_CLEAR_VSTOP(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 7.5.9, RS 9577: printed as the real-time call RSM_INTP_END
RSM_MP_CREATE(hRsm, 1, MP68);  // example RS 9577
RSM_MACRO_INTP_END(hRsm, 1, 0);
RSM_MACRO_MP_CLOSE(hRsm, 1);
