function r = zwidth_workspace(device, poses, normals, opts)
%ZWIDTH_WORKSPACE  K_cr of the wall at every pose and normal of a multi-DOF device (URDF).
%
%   dev = struct('sample_time', 1e-3, 'delay', 1e-3, 'kinematics', struct('preset', 'planar-2link'));
%   r = zwidth_workspace(dev, struct('explicit', {{[0.3, 1.0]}}), {[0, 1, 0]})
%   r = zwidth_workspace(dev, struct('latin_hypercube', struct('samples', 50, 'seed', 1)), 'worst')
%
%   DEVICE has sample_time [s], delay [s] and kinematics (urdf text and end_effector, or preset;
%   optional armature, joint_damping).  POSES is a struct with one of explicit (a cell of joint
%   vectors [rad or m]), grid (struct num) or latin_hypercube (struct samples, seed).  NORMALS is a
%   cell of unit 3-vectors in the base frame, or 'worst' (each pose's worst normal).  OPTS takes
%   damping (B of the wall [N*s/m]) and the connection options of ZWIDTH_REQUEST.
%
%   r.minimum_critical_stiffness [N/m], r.worst (pose, normal, critical_stiffness,
%   effective_mass [kg], one_dof_critical_stiffness), r.points, r.elapsed_ms.
%
%   See also ZWIDTH_ANALYZE, ZWIDTH_REQUEST.

  if nargin < 3 || isempty(normals), normals = 'worst'; end
  if nargin < 4, opts = struct(); end
  body = struct('device', device, 'poses', poses);
  body.normals = normals;
  if isfield(opts, 'damping'), body.controller = struct('stiffness', 1, 'damping', opts.damping); end
  r = zwidth_request('POST', '/v1/analysis/workspace', body, opts);
end
