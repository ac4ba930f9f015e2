%EXAMPLE_ENCODER_FRICTION  A quantised wall with Coulomb friction: its regime, and the encoder 20 kN/m needs.
%
%   Start a server first (`zwidth serve`), then in MATLAB or GNU Octave:
%       addpath('clients/matlab'); example_encoder_friction
%   Set ZWIDTH_URL (and ZWIDTH_API_TOKEN) to use another server.

% a small rigid device: 0.2 kg, 25 N*s/m, 1 kHz; a 10 um encoder, 0.1 N of friction, 10 cm of travel
device = struct('mass', 0.2, 'damping', 25, 'sample_time', 1e-3, ...
                'encoder_resolution', 1e-5, 'coulomb_friction', 0.1, 'travel', 0.1);

r = zwidth_analyze(device, struct('stiffness', 15000));
nl = r.nonlinear;
fprintf('K = 15 kN/m: regime %s (%s)\n', nl.regime, nl.reason);
fprintf('passive limit %.1f N/m = min(2b/T, 2f_c/q) [%s]\n', nl.passive_stiffness_limit, nl.source);
if nl.limit_cycle.exists
  fprintf('limit cycle: %.3g m at %.3g Hz (%s)\n', nl.limit_cycle.amplitude, nl.limit_cycle.frequency_hz, ...
          nl.limit_cycle.method);
end

% what encoder do I need for 20 kN/m?
h = zwidth_design_hardware(device, struct('stiffness', 2e4), 'encoder_resolution');
if strcmp(h.status, 'optimal')
  fprintf('20 kN/m needs q <= %.3g m per count: %.0f counts over the %.2f m travel (checked: %d)\n', ...
          h.value, h.quantisation.counts_over_travel, device.travel, h.quantisation.confirmed);
else
  fprintf('20 kN/m: %s\n', h.reason);
end
