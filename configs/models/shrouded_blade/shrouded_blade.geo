// One sector of a shrouded bladed disk (FricHB, configs/models/shrouded_blade).
//
// SI units (m). Axis of rotation: global z. The sector is centred on theta = 0 and spans
// theta = -phi/2 .. +phi/2 with phi = 2 pi / sectors.
//   disk:   annular sector r_hub..r_rim, z = -disk_width/2..+disk_width/2
//   blade:  plate standing radially on the rim from r_rim to r_tip along the x axis (theta = 0),
//           chord along z, thickness along y (circumferential), turned by `stagger` degrees
//           about its radial (x) axis
//   shroud: annular sector r_tip..r_tip + shroud_thickness, z = -shroud_width/2..+shroud_width/2,
//           over the whole sector angle: its side faces lie in the sector boundary planes, where
//           they touch the neighbouring sectors' shrouds
// Every parameter can be overridden: gmsh -setnumber NAME VALUE shrouded_blade.geo -3 ...
// The side faces of the disk and of the shroud get periodic meshes: each node of a right face
// (theta = +phi/2) is the +phi rotation about z of a node of the matching left face.
//
// Physical groups: volume "sector"; surfaces "bore" (r = r_hub, clamped by the driver),
// "disk_left", "disk_right", "shroud_left", "shroud_right", "shroud_top".
// configs/models/shrouded_blade/build_model.py drives it (mesh, CalculiX, conversion).

SetFactory("OpenCASCADE");

If (!Exists(sectors))          sectors = 8;          EndIf
If (!Exists(r_hub))            r_hub = 0.10;         EndIf
If (!Exists(r_rim))            r_rim = 0.20;         EndIf
If (!Exists(disk_width))       disk_width = 0.08;    EndIf
If (!Exists(r_tip))            r_tip = 0.55;         EndIf
If (!Exists(blade_chord))      blade_chord = 0.08;   EndIf
If (!Exists(blade_thickness))  blade_thickness = 0.02; EndIf
If (!Exists(stagger))          stagger = 0;          EndIf  // degrees
If (!Exists(shroud_thickness)) shroud_thickness = 0.012; EndIf  // radial
If (!Exists(shroud_width))     shroud_width = 0.05;  EndIf  // axial
If (!Exists(mesh_size))        mesh_size = 0.03;     EndIf  // largest element edge
If (!Exists(blade_mesh_size))  blade_mesh_size = mesh_size; EndIf  // in blade and shroud
If (!Exists(element_order))    element_order = 2;    EndIf  // 1: C3D4, 2: C3D10
// Structured contact faces: contact_n_r x contact_n_z vertex nodes on each shroud side face
// (a transfinite grid); 0 keeps the unstructured mesh of the faces.
If (!Exists(contact_n_r))      contact_n_r = 0;      EndIf  // vertex nodes along r
If (!Exists(contact_n_z))      contact_n_z = 0;      EndIf  // vertex nodes along z

phi = 2 * Pi / sectors;
c = Cos(phi / 2);
s = Sin(phi / 2);
r_out = r_tip + shroud_thickness;

// disk: an annular sector in the plane z = -disk_width/2, extruded axially
z0 = -disk_width / 2;
p1 = newp; Point(p1) = {0, 0, z0};
p2 = newp; Point(p2) = {r_hub * c, -r_hub * s, z0};
p3 = newp; Point(p3) = {r_rim * c, -r_rim * s, z0};
p4 = newp; Point(p4) = {r_rim * c, r_rim * s, z0};
p5 = newp; Point(p5) = {r_hub * c, r_hub * s, z0};
l1 = newl; Line(l1) = {p2, p3};
l2 = newl; Circle(l2) = {p3, p1, p4};
l3 = newl; Line(l3) = {p4, p5};
l4 = newl; Circle(l4) = {p5, p1, p2};
cl = newll; Curve Loop(cl) = {l1, l2, l3, l4};
sd = news; Plane Surface(sd) = {cl};
disk[] = Extrude {0, 0, disk_width} { Surface{sd}; };
Recursive Delete { Point{p1}; }

// shroud: the same construction between r_tip and r_out
z1 = -shroud_width / 2;
q1 = newp; Point(q1) = {0, 0, z1};
q2 = newp; Point(q2) = {r_tip * c, -r_tip * s, z1};
q3 = newp; Point(q3) = {r_out * c, -r_out * s, z1};
q4 = newp; Point(q4) = {r_out * c, r_out * s, z1};
q5 = newp; Point(q5) = {r_tip * c, r_tip * s, z1};
m1 = newl; Line(m1) = {q2, q3};
m2 = newl; Circle(m2) = {q3, q1, q4};
m3 = newl; Line(m3) = {q4, q5};
m4 = newl; Circle(m4) = {q5, q1, q2};
cm = newll; Curve Loop(cm) = {m1, m2, m3, m4};
ss = news; Plane Surface(ss) = {cm};
shroud[] = Extrude {0, 0, shroud_width} { Surface{ss}; };
Recursive Delete { Point{q1}; }

// blade: a box from inside the rim to the middle of the shroud, turned about its radial axis
overlap = 0.5 * blade_thickness + 0.5 * blade_chord * Sin(Fabs(stagger) * Pi / 180) ;
x0 = r_rim - overlap - 0.002 * r_rim;
x1 = r_tip + 0.5 * shroud_thickness;
bl = newv;
Box(bl) = {x0, -blade_thickness / 2, -blade_chord / 2,
           x1 - x0, blade_thickness, blade_chord};
Rotate {{1, 0, 0}, {0, 0, 0}, stagger * Pi / 180} { Volume{bl}; }

v[] = BooleanUnion{ Volume{disk[1]}; Delete; }{ Volume{shroud[1]}; Volume{bl}; Delete; };
If (#v[] != 1)
  Error("shrouded_blade.geo: the union of disk, blade and shroud is not one volume (%g)", #v[]);
  Abort;
EndIf

// boundary surfaces, found by the boxes that enclose them
e = 1e-6 * r_out;
dl[] = Surface In BoundingBox {r_hub * c - e, -r_rim * s - e, -disk_width / 2 - e,
                               r_rim * c + e, -r_hub * s + e, disk_width / 2 + e};
dr[] = Surface In BoundingBox {r_hub * c - e, r_hub * s - e, -disk_width / 2 - e,
                               r_rim * c + e, r_rim * s + e, disk_width / 2 + e};
sl[] = Surface In BoundingBox {r_tip * c - e, -r_out * s - e, -shroud_width / 2 - e,
                               r_out * c + e, -r_tip * s + e, shroud_width / 2 + e};
sr[] = Surface In BoundingBox {r_tip * c - e, r_tip * s - e, -shroud_width / 2 - e,
                               r_out * c + e, r_out * s + e, shroud_width / 2 + e};
bore[] = Surface In BoundingBox {r_hub * c - e, -r_hub * s - e, -disk_width / 2 - e,
                                 r_hub + e, r_hub * s + e, disk_width / 2 + e};
top[] = Surface In BoundingBox {r_out * c - e, -r_out * s - e, -shroud_width / 2 - e,
                                r_out + e, r_out * s + e, shroud_width / 2 + e};
If (#dl[] != 1 || #dr[] != 1 || #sl[] != 1 || #sr[] != 1 || #bore[] != 1 || #top[] != 1)
  Error("shrouded_blade.geo: boundary faces not found (%g %g %g %g %g %g)",
        #dl[], #dr[], #sl[], #sr[], #bore[], #top[]);
  Abort;
EndIf

Periodic Surface {dr[0]} = {dl[0]} Rotate {{0, 0, 1}, {0, 0, 0}, phi};
Periodic Surface {sr[0]} = {sl[0]} Rotate {{0, 0, 1}, {0, 0, 0}, phi};

// structured shroud side faces: the left face is a transfinite grid, the right face its copy
If (contact_n_r > 0 || contact_n_z > 0)
  If (contact_n_r < 2 || contact_n_z < 2)
    Error("shrouded_blade.geo: contact_n_r and contact_n_z must both be >= 2 (%g, %g)",
          contact_n_r, contact_n_z);
    Abort;
  EndIf
  // edges of the side face at theta = side * phi/2: the radial ones at z = +-shroud_width/2,
  // the axial ones at r = r_tip and r = r_out (Min/Max keep the box ordered)
  For side In {-1:1:2}
    cs = Cos(side * phi / 2);
    sn = Sin(side * phi / 2);
    For zs In {-1:1:2}
      zc = zs * shroud_width / 2;
      er[] = Curve In BoundingBox {
        Min(r_tip * cs, r_out * cs) - e, Min(r_tip * sn, r_out * sn) - e, zc - e,
        Max(r_tip * cs, r_out * cs) + e, Max(r_tip * sn, r_out * sn) + e, zc + e};
      If (#er[] != 1)
        Error("shrouded_blade.geo: radial edge of a shroud side face not found (%g)", #er[]);
        Abort;
      EndIf
      Transfinite Curve {er[0]} = contact_n_r;
    EndFor
    For k In {0:1}
      rc = r_tip + k * shroud_thickness;
      ez[] = Curve In BoundingBox {rc * cs - e, rc * sn - e, -shroud_width / 2 - e,
                                   rc * cs + e, rc * sn + e, shroud_width / 2 + e};
      If (#ez[] != 1)
        Error("shrouded_blade.geo: axial edge of a shroud side face not found (%g)", #ez[]);
        Abort;
      EndIf
      Transfinite Curve {ez[0]} = contact_n_z;
    EndFor
  EndFor
  Transfinite Surface {sl[0]};
EndIf

Physical Volume("sector") = {v[0]};
Physical Surface("bore") = {bore[0]};
Physical Surface("disk_left") = {dl[0]};
Physical Surface("disk_right") = {dr[0]};
Physical Surface("shroud_left") = {sl[0]};
Physical Surface("shroud_right") = {sr[0]};
Physical Surface("shroud_top") = {top[0]};

// mesh: size mesh_size in the disk, blade_mesh_size in the blade and the shroud
Mesh.CharacteristicLengthMax = mesh_size;
Mesh.CharacteristicLengthMin = 0;
Mesh.CharacteristicLengthFromCurvature = 0;
Mesh.CharacteristicLengthExtendFromBoundary = 1;
If (blade_mesh_size < mesh_size)
  Field[1] = Box;
  Field[1].VIn = blade_mesh_size;
  Field[1].VOut = mesh_size;
  Field[1].XMin = r_rim - 0.5 * (r_rim - r_hub);
  Field[1].XMax = r_out * 1.01;
  Field[1].YMin = -r_out; Field[1].YMax = r_out;
  Field[1].ZMin = -r_out; Field[1].ZMax = r_out;
  Background Field = 1;
EndIf
Mesh.ElementOrder = element_order;
Mesh.SecondOrderLinear = 1;   // straight-sided elements: mass = rho * (sum of tet volumes)
Mesh.Optimize = 1;
Mesh.SaveGroupsOfNodes = 1;   // *NSET per physical group in the Abaqus .inp
