%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
MODULE FaceMill
    ! Face milling 200 x 150 mm, zig-zag, 15 mm stepover (robolobe example)
    PERS tooldata tSpindle:=[TRUE,[[0,0,380],[1,0,0,0]],[55,[0,0,-180],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wPart:=[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    CONST speeddata vFace:=[25,500,5000,1000];
    CONST robtarget pStart:=[[0,0,-1.5],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pAbove:=[[0,0,40],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    VAR triggdata trRobolobeSpindle;
    CONST speeddata vRl1:=[23.616666667,500,5000,1000]; ! ROBOLOBE 1417 mm/min
    CONST speeddata vRl2:=[23.633333333,500,5000,1000]; ! ROBOLOBE 1418 mm/min
    CONST speeddata vRl3:=[23.65,500,5000,1000]; ! ROBOLOBE 1419 mm/min
    CONST speeddata vRl4:=[23.666666667,500,5000,1000]; ! ROBOLOBE 1420 mm/min
    CONST speeddata vRl5:=[23.683333333,500,5000,1000]; ! ROBOLOBE 1421 mm/min
    CONST speeddata vRl6:=[23.7,500,5000,1000]; ! ROBOLOBE 1422 mm/min
    CONST speeddata vRl7:=[23.716666667,500,5000,1000]; ! ROBOLOBE 1423 mm/min
    CONST speeddata vRl8:=[23.733333333,500,5000,1000]; ! ROBOLOBE 1424 mm/min
    CONST speeddata vRl9:=[23.75,500,5000,1000]; ! ROBOLOBE 1425 mm/min
    CONST speeddata vRl10:=[23.766666667,500,5000,1000]; ! ROBOLOBE 1426 mm/min
    CONST speeddata vRl11:=[23.783333333,500,5000,1000]; ! ROBOLOBE 1427 mm/min
    CONST speeddata vRl12:=[23.8,500,5000,1000]; ! ROBOLOBE 1428 mm/min
    CONST speeddata vRl13:=[23.816666667,500,5000,1000]; ! ROBOLOBE 1429 mm/min
    CONST speeddata vRl14:=[23.833333333,500,5000,1000]; ! ROBOLOBE 1430 mm/min
    CONST speeddata vRl15:=[23.85,500,5000,1000]; ! ROBOLOBE 1431 mm/min
    CONST speeddata vRl16:=[23.866666667,500,5000,1000]; ! ROBOLOBE 1432 mm/min
    CONST speeddata vRl17:=[23.883333333,500,5000,1000]; ! ROBOLOBE 1433 mm/min
    CONST speeddata vRl18:=[23.9,500,5000,1000]; ! ROBOLOBE 1434 mm/min
    CONST speeddata vRl19:=[23.916666667,500,5000,1000]; ! ROBOLOBE 1435 mm/min
    CONST speeddata vRl20:=[23.933333333,500,5000,1000]; ! ROBOLOBE 1436 mm/min
    CONST speeddata vRl21:=[23.95,500,5000,1000]; ! ROBOLOBE 1437 mm/min
    CONST speeddata vRl22:=[23.966666667,500,5000,1000]; ! ROBOLOBE 1438 mm/min
    CONST speeddata vRl23:=[23.983333333,500,5000,1000]; ! ROBOLOBE 1439 mm/min

    PROC main()
        ConfL \Off;
        SingArea \Wrist;
        SetAO aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm (1000 rpm per unit)
        MoveJ pAbove, v500, z20, tSpindle\WObj:=wPart;
        MoveL pStart, vRl1, fine, tSpindle\WObj:=wPart; ! ROBOLOBE speed v10 -> vRl1
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,200,0,0), vRl2, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl2; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,200,15,0), vRl3, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl3; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,0,15,0), vRl4, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl4; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,0,30,0), vRl5, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl5; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,200,30,0), vRl6, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl6; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,200,45,0), vRl7, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl7; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,0,45,0), vRl8, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl8; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,0,60,0), vRl9, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl9; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,200,60,0), vRl10, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl10; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,200,75,0), vRl11, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl11; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,0,75,0), vRl12, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl12; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,0,90,0), vRl13, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl13; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,200,90,0), vRl14, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl14; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,200,105,0), vRl15, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl15; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,0,105,0), vRl16, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl16; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,0,120,0), vRl17, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl17; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,200,120,0), vRl18, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl18; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,200,135,0), vRl19, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl19; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,0,135,0), vRl20, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl20; spindle 6000 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.3; ! ROBOLOBE spindle speed 6300 rpm
        TriggL Offs(pStart,0,150,0), vRl21, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl21; spindle 6300 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6.6; ! ROBOLOBE spindle speed 6600 rpm
        TriggL Offs(pStart,200,150,0), vRl22, trRobolobeSpindle, z1, tSpindle\WObj:=wPart; ! ROBOLOBE speed vFace -> vRl22; spindle 6600 rpm
        TriggIO trRobolobeSpindle, 0 \Start \AOp:=aoSpindle, 6; ! ROBOLOBE spindle speed 6000 rpm
        TriggL Offs(pStart,200,150,40), vRl23, trRobolobeSpindle, z10, tSpindle\WObj:=wPart; ! ROBOLOBE speed v200 -> vRl23; spindle 6000 rpm
    ENDPROC
ENDMODULE
