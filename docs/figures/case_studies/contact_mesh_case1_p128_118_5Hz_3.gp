set terminal pngcairo size 900,420 noenhanced
set output 'contact_mesh_case1_p128_118_5Hz_3.png'
set datafile separator ','
set grid
set size ratio -1
set key off
set title 'case 1 (EO3, 1D friction, N0 = 5 N): share of the period stuck, 128 pairs, 118.5Hz_3'
set xlabel 'along tangent1 (axial) from the face centroid [mm]'
set ylabel 'along tangent2 [mm]'
set cbrange [0:1]
set cblabel 'share of the period stuck'
set palette defined (0 'red', 0.5 'yellow', 1 'blue')
plot 'contact_mesh_case1_p128_118_5Hz_3.csv' using (1000*column('face_s1_m')):(1000*column('face_s2_m')):'stuck' with points pt 7 ps 2 palette
