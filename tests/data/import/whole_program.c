/*
 * glue_cell.c - downloads the glue cell's macro programs into an RS-M8194H.
 *
 * MP100 runs the bead 100 times; ISR1 opens the valve when X passes COMP+.
 * Written against the vendor DLL as the manual's chapter 7.3 examples are.
 */
#include <stdio.h>
#include "RSM8194H.h"

#define BEAD_LENGTH   42000L         /* pulses */
#define VALVE_AT      (BEAD_LENGTH - 4000)
#define BEADS         VAR10
const long SETTLE_MS = 250;

int main(void)
{
    HANDLE hRsm;
    BYTE SlaveAddr = 1;
    long speed = 2000;
    int i;

    hRsm = RSM_OPEN_COM_PORT(1, 115200, 8, 0, 1);
    if (hRsm == NULL) {
        printf("no controller\n");
        return 1;
    }

    RSM_MP_CREATE(hRsm, SlaveAddr, MP100); //Create a macro program MP100.
    RSM_MACRO_SET_MAX_V(hRsm, SlaveAddr, AXIS_XY, 8000);
    // Set the maximum speed of XY axes on module 1 to 8K PPS.
    RSM_MACRO_NORMAL_SPEED(hRsm, SlaveAddr, AXIS_XY, 0);
    RSM_MACRO_SET_V(hRsm, SlaveAddr, AXIS_XY, 2000);
    RSM_MACRO_SET_A(hRsm, SlaveAddr, AXIS_XY, 100000);
    RSM_MACRO_SET_SV(hRsm, SlaveAddr, AXIS_XY, 100);
    RSM_MACRO_SET_VAR(hRsm, SlaveAddr, BEADS, 0);   /* beads laid so far */

    RSM_MACRO_FOR(hRsm, SlaveAddr, 100); //Set the times of for loop is 100.
    RSM_MACRO_SET_LP(hRsm, SlaveAddr, AXIS_XY, 0);
    RSM_MACRO_CLEAR_SYNC_ACTION(hRsm, SlaveAddr, AXIS_X);
    RSM_MACRO_SYNC_ACTION(hRsm, SlaveAddr, AXIS_X, AXIS_X,
                          0X00000001, 0, 0, 0, 0, 1, ISR1, 0, 0, 0);
    // Set the LP value of X axis exceeds COMP+, it will generate an interrupt to
    // call ISR1.
    RSM_MACRO_ENABLE_INT(hRsm, SlaveAddr); //Enable interrupt
    RSM_MACRO_SET_COMPARE(hRsm, SlaveAddr, AXIS_X, 0, 0, VALVE_AT);
    RSM_MACRO_FIXED_MOVE(hRsm, SlaveAddr, AXIS_X, BEAD_LENGTH);
    RSM_MACRO_STOP_WAIT(hRsm, SlaveAddr, AXIS_X); //Wait until X axis stop.
    RSM_MACRO_VAR_CALCULATE(hRsm, SlaveAddr, BEADS, '+', 1, BEADS);
    RSM_MACRO_TIMER(hRsm, SlaveAddr, SETTLE_MS);
    RSM_MACRO_IF(hRsm, SlaveAddr, BEADS, ">=", 50);
        RSM_MACRO_EXIT_FOR(hRsm, SlaveAddr);   // half the batch is enough today
    RSM_MACRO_END_IF(hRsm, SlaveAddr);
    for (i = 0; i < 2; i++)
        RSM_MACRO_FIXED_MOVE(hRsm, SlaveAddr, AXIS_Y, 500);
    RSM_MACRO_FIXED_MOVE(hRsm, SlaveAddr, AXIS_Y, speed);
    RSM_MACRO_GET_HOME_STATE(hRsm, SlaveAddr, AXIS_X);
    RSM_SET_V(hRsm, SlaveAddr, AXIS_X, 100);
    RSM_MACRO_NEXT(hRsm, SlaveAddr); //Match with for loop.
    RSM_MACRO_MP_CLOSE(hRsm, SlaveAddr); // End a macro program MP100

ISR1:
    RSM_MP_ISR_CREATE(hRsm, SlaveAddr, ISR1); //Create ISR1
    RSM_MACRO_FRNET_OUT(hRsm, SlaveAddr, 0, 0x0004);  // valve on
    RSM_MACRO_GET_LP(hRsm, SlaveAddr, AXIS_X);
    RSM_MACRO_SET_RVAR(hRsm, SlaveAddr, VAR31);       // where it opened
    RSM_MACRO_SYNC_ACTION(hRsm, SlaveAddr, AXIS_X, AXIS_X,
    0X00000040, 6, 0, 0, 0, 0, 0, 0, 0); //Set the X axis to receive the IN3
    RSM_MACRO_MP_ISR_CLOSE(hRsm, SlaveAddr); // End ISR1

    RSM_MP_CALL(hRsm, SlaveAddr, MP100); // Execute the MP100
    RSM_CLOSE_COM_PORT(hRsm);
    return 0;
}
