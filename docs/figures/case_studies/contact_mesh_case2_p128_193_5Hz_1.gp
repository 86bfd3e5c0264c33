set terminal pngcairo size 900,420 noenhanced
set output 'contact_mesh_case2_p128_193_5Hz_1.png'
set datafile separator ','
set grid
set size ratio -1
set key off
set title 'case 2 (EO1, 3D coupled friction, N0 = 1 N): share of the period stuck, 128 pairs, 193.5Hz_1'
set xlabel 'along tangent1 (axial) from the face centroid [mm]'
set ylabel 'along tangent2 [mm]'
set cbrange [0:1]
set cblabel 'share of the period stuck'
set palette defined (0 'red', 0.5 'yellow', 1 'blue')
plot 'contact_mesh_case2_p128_193_5Hz_1.csv' using (1000*column('face_s1_m')):(1000*column('face_s2_m')):'stuck' with points pt 7 ps 2 palette
