/* The worked examples of the RS-M8194H API manual v3.1, chapter 9 (macro programming),
 * transcribed from the call printed above each example's register table (the RS line
 * numbers refer to shared/manuals/001_404865bff90dda3e.txt). Each example is one macro
 * program; where the example is about one command of a block (NEXT, ELSE, LABEL, ...) the
 * program holds the whole block, as the manual's related examples do. Where the manual
 * prints the real-time call RSM_X the macro call RSM_MACRO_X is written, with the printed
 * arguments. tests/data/manual_examples.toml holds the frames. */

#include "RSM8194H.h"

// 9.1.2, RS 9905
RSM_MP_CREATE(hRsm, 1, MP1);  // example RS 9905
RSM_MACRO_MP_CLOSE (hRsm, 1);
// module 1 finish, write Macro Program into i-8094H

// 9.1.3, RS 9951: printed as the real-time call RSM_MP_CALL
RSM_MP_CREATE(hRsm, 1, MP2);  // example RS 9951
//The true value of MPn = n; therefore, MP21 = 21 = 0x15.
RSM_MACRO_MP_CALL (hRsm, 1, MP21); // Execute the MP21 on i-8094H
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.2.2, RS 10071
RSM_MP_ISR_CREATE (hRsm, 1, ISR1);  // example RS 10071
RSM_MACRO_MP_ISR_CLOSE (hRsm, 1);
// finish the writing of ISR Macro Program for i-8094H in slot 1

// 9.3.1, RS 10159
RSM_MP_CREATE(hRsm, 1, MP3);  // example RS 10159
RSM_MACRO_SET_VAR(hRsm, 1, VAR1, 100); // VAR1 = 100
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.3.2, RS 10218
RSM_MP_CREATE(hRsm, 1, MP4);  // example RS 10218
RSM_MACRO_SET_RVAR(hRsm, 1, VAR5);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.4, RS 10298
RSM_MP_CREATE(hRsm, 1, MP5);  // example RS 10298
RSM_MACRO_VAR_CALCULATE (hRsm, 1, VAR1, '+', VAR2, VAR3);
//VAR1 + VAR2 = VAR3
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.5.1, RS 10390
RSM_MP_CREATE(hRsm, 1, MP6);  // example RS 10390
// The address of VARn = 0x7FFF0000 + n;
RSM_MACRO_FOR (hRsm, 1, VAR1);
RSM_MACRO_NEXT(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.5.2, RS 10467
RSM_MP_CREATE(hRsm, 1, MP7);  // example RS 10467
RSM_MACRO_FOR(hRsm, 1, VAR1);
RSM_MACRO_NEXT (hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.5.3, RS 10500
RSM_MP_CREATE(hRsm, 1, MP8);  // example RS 10500
RSM_MACRO_FOR(hRsm, 1, VAR1);
RSM_MACRO_EXIT_FOR (hRsm, 1);
RSM_MACRO_NEXT(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.6.1, RS 10565
RSM_MP_CREATE(hRsm, 1, MP9);  // example RS 10565
RSM_MACRO_IF (hRsm, 1, VAR1, "<=", VAR2);
RSM_MACRO_END_IF(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.6.2, RS 10647
RSM_MP_CREATE(hRsm, 1, MP10);  // example RS 10647
RSM_MACRO_IF(hRsm, 1, VAR1, "<=", VAR2);
RSM_MACRO_ELSE (hRsm, 1);
RSM_MACRO_END_IF(hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.6.3, RS 10680
RSM_MP_CREATE(hRsm, 1, MP11);  // example RS 10680
RSM_MACRO_IF(hRsm, 1, VAR1, "<=", VAR2);
RSM_MACRO_END_IF (hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.7.1, RS 10727
RSM_MP_CREATE(hRsm, 1, MP12);  // example RS 10727
RSM_MACRO_GOTO (hRsm, 1, 3);
RSM_MACRO_LABEL(hRsm, 1, 3);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.7.2, RS 10766
RSM_MP_CREATE(hRsm, 1, MP13);  // example RS 10766
RSM_MACRO_GOTO(hRsm, 1, LABEL3);
RSM_MACRO_LABEL (hRsm, 1, 3);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.8, RS 10802
RSM_MP_CREATE(hRsm, 1, MP14);  // example RS 10802
RSM_MACRO_TIMER (hRsm, 1, 200);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.9, RS 10849: printed as the real-time call RSM_STOP_WAIT
RSM_MP_CREATE(hRsm, 1, MP15);  // example RS 10849
RSM_MACRO_STOP_WAIT (hRsm, 1, AXIS_Y);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.10, RS 10886
RSM_MP_CREATE(hRsm, 1, MP16);  // example RS 10886
RSM_MACRO_EXIT_MACRO (hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);

// 9.11, RS 10932: printed as the real-time call RSM_MP_TERMINATE
RSM_MP_CREATE(hRsm, 1, MP17);  // example RS 10932
RSM_MACRO_MP_TERMINATE (hRsm, 1);
RSM_MACRO_MP_CLOSE(hRsm, 1);
