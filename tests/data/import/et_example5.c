/* ET-M8194H manual, 7.3.1 synchronous actions, Example 5 (ET 11907-11951, the same listing
 * as RS 7249-7308), transcribed with the ETM_ names. The PDF conversion split three names
 * ("ETM_ MACRO_SET_A", "ETM_ MACRO_SET_SV", "ETM_ MACRO_SET_LP"); they are written whole.
 * Everything else is as printed, including what the device would refuse: SET_MAX_V 5000 is
 * below the 8000 PPS minimum (RS 1158), and with that corrected MP59 would need 17 lines of
 * its 16 (the RS print of the ISR's SYNC_ACTION also lacks an argument, RS 7305-7306; the ET
 * print has all twelve). */

//Example5: Use the for loop to iterate, when the LP value of X axis
//exceeds COMP+(38000), it will generate an interrupt to call ISR1, and
// determine whether receive IN3 signal in the ISR1, if receive then
// emergency stop.
ETM_MP_CREATE(hEtm, cardNo, MP59); //Create a macro program MP59.
ETM_MACRO_SET_MAX_V(hEtm, cardNo, AXIS_XY, 5000);
// Set the maximum speed of XY axes on module 1 to 5K PPS.
ETM_MACRO_NORMAL_SPEED(hEtm, cardNo, AXIS_XY, 0);
// set the speed profile for XY axes as symmetric T-curve.
ETM_MACRO_SET_V(hEtm, cardNo, AXIS_XY, 2000);
// set the speed of XY axes on module 1 to 2000 PPS.
ETM_MACRO_SET_A(hEtm, cardNo, AXIS_XY, 100000);
// set the acceleration value of XY axes to 100K PPS/S.
ETM_MACRO_SET_SV(hEtm, cardNo, AXIS_XY, 100);
// set the start velocity of XY axes to 100 PPS.
ETM_MACRO_FOR(hEtm, cardNo, 100); //Set the times of for loop is 100.
ETM_MACRO_SET_LP(hEtm, cardNo, AXIS_XY, 0);
//Set the LP value of XYaxes to 0
ETM_MACRO_SET_FILTER(hEtm, cardNo, AXIS_X, 16, 1); //Set the filter of IN3
ETM_MACRO_CLEAR_SYNC_ACTION(hEtm, cardNo, AXIS_X);
//Clear all the  sync_action conditions of X axis.
ETM_MACRO_SYNC_ACTION(hEtm, cardNo, AXIS_X, AXIS_X, 0X00000001, 0, 0,

 0, 0, 1, ISR1, 0, 0, 0);
// Set the LP value of X axis exceeds COMP+, it will generate an interrupt to
// call ISR1.
ETM_MACRO_ENABLE_INT(hEtm, cardNo);  //Enable interrupt
ETM_MACRO_SET_COMPARE(hEtm, cardNo, AXIS_X, 0, 0, 38000);
//Set the value of COMP+ is 38000, source reference the LP of X axis.
ETM_MACRO_FIXED_MOVE(hEtm, cardNo, AXIS_X, 42000);
// move 42K Pulses for X axis on module 1
ETM_MACRO_STOP_WAIT(hEtm, cardNo, AXIS_X); //Wait until X axis stop.
ETM_MACRO_NEXT(hEtm, cardNo); //Match with for loop.
ETM_MACRO_MP_CLOSE(hEtm, cardNo); // End a macro program MP59


ISR1:
ETM_MP_ISR_CREATE(hEtm, cardNo, ISR1); //Create ISR1
ETM_MACRO_FIXED_MOVE(hEtm, cardNo, AXIS_Y, 1000);
// move 1000 Pulses for Y axis on module 1.
ETM_MACRO_SYNC_ACTION(hEtm, cardNo, AXIS_X, AXIS_X, 0X00000040, 6, 0,

 0, 0, 0, 0, 0, 0, 0); //Set the X axis to receive the IN3 positive edge trigger
//signals from low level to high level, then emergency stop.
ETM_MACRO_MP_ISR_CLOSE(hEtm, cardNo); // End ISR1
