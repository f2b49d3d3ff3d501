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

    PROC main()
        ConfL \Off;
        SingArea \Wrist;
        MoveJ pAbove, v500, z20, tSpindle\WObj:=wPart;
        MoveL pStart, v10, fine, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,0,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,15,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,15,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,30,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,30,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,45,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,45,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,60,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,60,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,75,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,75,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,90,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,90,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,105,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,105,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,120,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,120,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,135,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,135,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,0,150,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,150,0), vFace, z1, tSpindle\WObj:=wPart;
        MoveL Offs(pStart,200,150,40), v200, z10, tSpindle\WObj:=wPart;
    ENDPROC
ENDMODULE
