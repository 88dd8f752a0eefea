% Intrinsic and Extrinsic Camera Parameters
%
% This script file can be directly executed under Matlab to recover the camera intrinsic and extrinsic parameters.
% IMPORTANT: This file contains neither the structure of the calibration objects nor the image coordinates of the calibration points.
%            All those complementary variables are saved in the complete matlab data file Calib_Results.mat.
% (An example in the layout of Bouguet's Camera Calibration Toolbox for Matlab; values made up.)


%-- Focal length:
fc = [ 1102.345678901234500 ; 1101.234567890123400 ];

%-- Principal point:
cc = [ 321.456789012345670 ; 240.345678901234560 ];

%-- Skew coefficient:
alpha_c = 0.000000000000000;

%-- Distortion coefficients:
kc = [ -0.123456789012346 ; 0.087654321098765 ; 0.000543210987654 ; -0.000321098765432 ; 0.000000000000000 ];

%-- Focal length uncertainty:
fc_error = [ 1.569282671152671 ; 1.461154863082004 ];

%-- Principal point uncertainty:
cc_error = [ 2.286222691982841 ; 1.902443125481905 ];

%-- Skew coefficient uncertainty:
alpha_c_error = 0.000000000000000;

%-- Distortion coefficients uncertainty:
kc_error = [ 0.012730833002324 ; 0.038827084194026 ; 0.001933599829770 ; 0.002380503971426 ; 0.000000000000000 ];

%-- Image size:
nx = 640;
ny = 480;


%-- Various other variables (may be ignored if you do not use the Matlab Calibration Toolbox):
%-- Those variables are used to control which intrinsic parameters should be optimized

n_ima = 20;						% Number of calibration images
est_fc = [ 1 ; 1 ];					% Estimation indicator of the two focal variables
est_aspect_ratio = 1;				% Estimation indicator of the aspect ratio fc(2)/fc(1)
center_optim = 1;					% Estimation indicator of the principal point
est_alpha = 0;						% Estimation indicator of the skew coefficient
est_dist = [ 1 ; 1 ; 1 ; 1 ; 0 ];	% Estimation indicator of the distortion coefficients

KK = [fc(1) alpha_c*fc(1) cc(1);0 fc(2) cc(2) ; 0 0 1];
