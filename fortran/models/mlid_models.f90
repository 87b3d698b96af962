!> The model interface and its implementations.
!>
!> A model is xdot = f(t, x, [u; w], p), y = h(t, x, u, p) with analytic
!> Jacobians, where w (nw values) is process noise held over a sample
!> interval and entering like extra inputs.  Every estimator works on the
!> full parameter vector (offsets in layout_t)
!>
!>     theta = [ p(np), x0(nx), bias(ny), q(nw), r(ny), s(nw*ny), delay(ny), udelay(nu),
!>               stab(nx*ny), p0(nx) ]
!>
!> with q and r the variances of process and measurement noise (diagonal Q
!> and R), s their cross-covariance S (nw x ny, column-major) and delay each
!> output's time delay (s, mlid_delay), udelay each input's, stab the fixed
!> gain of the stabilized output error (mlid_filter) or, with filter_params =
!> 'gain', the filter's steady-state gain K (report eq. 4.19), and p0 the
!> diagonal of the Kalman filter's initial covariance P(1|0) (mlid_filter).  Initial states, biases, noise
!> statistics and delays are thus parameters of every model,
!> free or fixed like any other; the model itself only sees p.
!> A model whose outputs carry the process noise too (accelerometers, §5.1)
!> overrides dhdw: y = h + (dh/dw) w, with the w of the interval that
!> follows the sample; by default they do not.
module mlid_models
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: model_t, linear_model_t, layout_t, model_layout, NZ_HROWS

  type, abstract :: model_t
    integer :: nx = 0  !< states
    integer :: nu = 0  !< inputs
    integer :: ny = 0  !< outputs
    integer :: nw = 0  !< process-noise inputs
    integer :: np = 0  !< model parameters (before x0 and bias)
    logical :: linear = .false.  !< f and h linear in x and u (the Kalman filter needs it)
  contains
    !> The model at one point: what a model writes.  f, h and their
    !> Jacobians below ask it for one quantity each.
    procedure(eval_iface), deferred :: eval
    procedure :: f => point_f
    procedure :: h => point_h
    procedure :: dfdx => point_dfdx
    procedure :: dfdp => point_dfdp
    procedure :: dhdx => point_dhdx
    procedure :: dhdp => point_dhdp
    procedure(dfdw_iface), deferred :: dfdw
    procedure(dhdxp_iface), deferred :: dhdxp
    procedure :: dhdw => no_output_noise
    !> df/du and dh/du (nx or ny, nu): what input time delays need; a model
    !> that gives them says so in has_input_jacobians.
    procedure :: has_input_jacobians => no_input_jacobians
    procedure :: dfdu => zero_input_jacobian
    procedure :: dhdu => zero_input_jacobian
    !> The model over a stretch of record where some inputs keep one value
    !> (a manoeuvre's indicator): a model that gets cheaper with them known
    !> returns itself so specialised, and says which of its parameters it
    !> still reads; the others leave it unallocated.
    procedure :: fold_inputs => no_folding
    procedure :: uses_params => reads_every_param
    !> param_rows(idx, frow, hrow): the structure of eval's b and d for the
    !> parameters idx, for the sensitivity recursions to add the entries
    !> that can be nonzero alone.  b(:, k) = df/dp(idx(k)) is zero outside
    !> row frow(k), d(:, k) = dh/dp(idx(k)) outside the rows hrow(:, k)
    !> (NZ_HROWS or fewer, the rest 0); frow(k) = 0 or hrow(1, k) = 0: any
    !> row can be nonzero, as by default.  A promise for every x, u and p:
    !> the rows not named are exactly zero (eval writes them as 0), so a
    !> sum that leaves them out has the same value.  Naming a row that
    !> happens to be zero is allowed; leaving out one that is not is wrong.
    procedure :: param_rows => every_param_row
    !> measured_states(p, which, known): which(i) the state output i is
    !> (y_i = x_j whatever x and u, bias apart: its first sample is that
    !> state's first value), 0 for none; known false: the kind cannot say.
    procedure :: measured_states => cannot_say
  end type model_t

  !> How many rows of a column of dh/dp param_rows can name.
  integer, parameter :: NZ_HROWS = 2

  abstract interface
    !> The model at (t, x, u): each quantity asked for (present) of
    !>   xdot = f(t, x, u, p),  a = df/dx (nx, nx),  b(:, k) = df/dp(idx(k)),
    !>   y = h(t, x, u, p) (without bias),  c = dh/dx (ny, nx),  d(:, k) = dh/dp(idx(k)),
    !> from one computation of what they share (the sensitivity equations
    !> want f, a and b at every RK4 stage, the outputs y, c and d at every
    !> sample, and both at once at a sample where a step starts).  u may
    !> carry the process noise after the inputs (f takes it, h does not).
    !> x and the results have explicit shapes (nx, ny and size(idx)): a
    !> point, asked for at every stage and sample, sets up no array
    !> descriptors for them, and the model's loops run on unit strides.
    pure subroutine eval_iface(self, t, x, u, p, idx, xdot, a, b, y, c, d)
      import :: model_t, wp
      class(model_t), intent(in) :: self
      real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
      integer, intent(in) :: idx(:)
      real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                           y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    end subroutine eval_iface
    !> g = df/dw (nx, nw): how the process noise enters.
    pure subroutine dfdw_iface(self, t, x, u, p, g)
      import :: model_t, wp
      class(model_t), intent(in) :: self
      real(wp), intent(in) :: t, x(:), u(:), p(:)
      real(wp), intent(out) :: g(:, :)
    end subroutine dfdw_iface
    !> dc(:, :, k) = d(dh/dx)/dp(idx(k)), for the filter's covariance partials.
    pure subroutine dhdxp_iface(self, t, x, u, p, idx, dc)
      import :: model_t, wp
      class(model_t), intent(in) :: self
      real(wp), intent(in) :: t, x(:), u(:), p(:)
      integer, intent(in) :: idx(:)
      real(wp), intent(out) :: dc(:, :, :)
    end subroutine dhdxp_iface
  end interface

  !> Where each block of theta starts (offset: block entry k is theta(o + k)).
  !> A record of several manoeuvres (segments) has an initial state and a
  !> bias vector per segment: the x0 block holds nx*nseg entries, segment
  !> by segment, and the bias block ny*nseg; seg(k) is the first sample of
  !> segment k.
  type :: layout_t
    integer :: np = 0, nx = 0, ny = 0, nw = 0, nseg = 1
    integer :: ox0 = 0, obias = 0, oq = 0, or = 0, os = 0, odelay = 0, oudelay = 0, ostab = 0, &
               op0 = 0
    integer :: nth = 0
    integer :: nu = 0
    integer, allocatable :: seg(:)
  end type layout_t

  !> Linear state space xdot = F x + G (u + K x) + bx + Gamma w,
  !> y = H x + D (u + K x): K (nu x nx) feeds states back to the inputs
  !> (a stability augmentation system acting on top of the recorded
  !> command); it is zero unless a case says otherwise.  bx (nx): constant
  !> state-equation biases (trim offsets, the textbook's Z0, M0).
  !> p = [vec(F), vec(G), vec(H), vec(D), vec(Gamma), vec(K), bx], each column-major.
  type, extends(model_t) :: linear_model_t
    integer :: of = 0, og = 0, oh = 0, od = 0, ogam = 0, ok = 0, obx = 0  !< offsets in p
  contains
    procedure :: eval => lin_eval
    procedure :: dfdw => lin_dfdw
    procedure :: dhdxp => lin_dhdxp
    procedure :: has_input_jacobians => lin_input_jacobians
    procedure :: dfdu => lin_dfdu
    procedure :: dhdu => lin_dhdu
    procedure :: matrices => lin_matrices
    procedure :: measured_states => lin_measured_states
  end type linear_model_t

contains

  !> dw = dh/dw (ny, nw): zero, the outputs carry no process noise.
  pure subroutine no_output_noise(self, t, x, u, p, dw)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: dw(:, :)
    dw = 0.0_wp
  end subroutine no_output_noise

  pure logical function no_input_jacobians(self)
    class(model_t), intent(in) :: self
    no_input_jacobians = .false.
  end function no_input_jacobians


  !> Never called: a model without input Jacobians is refused input delays.
  pure subroutine zero_input_jacobian(self, t, x, u, p, b)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: b(:, :)
    b = 0.0_wp
  end subroutine zero_input_jacobian

  subroutine no_folding(self, fixed, val, folded)
    class(model_t), intent(in) :: self
    logical, intent(in) :: fixed(:)           !< the inputs that keep one value
    real(wp), intent(in) :: val(:)            !< the inputs' values (those of the fixed ones count)
    class(model_t), allocatable, intent(out) :: folded
  end subroutine no_folding

  !> F, G, H, D and the input feedback K of the linear model at p: the one
  !> place that knows how they lie in p (the fast path, the frequency
  !> domain and the frequency responses read them here).
  pure subroutine lin_matrices(self, p, f, g, h, d, k)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    real(wp), intent(out) :: f(:, :), g(:, :), h(:, :), d(:, :), k(:, :)
    associate (nx => self%nx, nu => self%nu, ny => self%ny)
      f = reshape(p(self%of + 1:self%of + nx*nx), [nx, nx])
      g = reshape(p(self%og + 1:self%og + nx*nu), [nx, nu])
      h = reshape(p(self%oh + 1:self%oh + ny*nx), [ny, nx])
      d = reshape(p(self%od + 1:self%od + ny*nu), [ny, nu])
      k = reshape(p(self%ok + 1:self%ok + nu*nx), [nu, nx])
    end associate
  end subroutine lin_matrices

  !> A kind that does not say which output is which state (model_t%measured_states).
  pure subroutine cannot_say(self, p, which, known)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(out) :: which(:)
    logical, intent(out) :: known
    which = 0
    known = .false.
  end subroutine cannot_say

  !> Output i is state j when its row of H is the unit vector e_j and its
  !> row of D is zero (then D K x adds nothing either).
  pure subroutine lin_measured_states(self, p, which, known)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(out) :: which(:)
    logical, intent(out) :: known
    real(wp) :: f(self%nx, self%nx), g(self%nx, self%nu), h(self%ny, self%nx), &
                d(self%ny, self%nu), k(self%nu, self%nx)
    integer :: i, j
    call self%matrices(p, f, g, h, d, k)
    which = 0
    known = .true.
    do i = 1, self%ny
      j = findloc(h(i, :), 1.0_wp, 1)
      if (j == 0 .or. count(h(i, :) /= 0.0_wp) /= 1 .or. any(d(i, :) /= 0.0_wp)) cycle
      which(i) = j
    end do
  end subroutine lin_measured_states

  !> Dense Jacobians (param_rows): any row of df/dp and dh/dp can be nonzero.
  pure subroutine every_param_row(self, idx, frow, hrow)
    class(model_t), intent(in) :: self
    integer, intent(in) :: idx(:)
    integer, intent(out) :: frow(size(idx)), hrow(NZ_HROWS, size(idx))
    frow = 0
    hrow = 0
  end subroutine every_param_row

  !> used(k): whether parameter k enters f or h.
  pure subroutine reads_every_param(self, used)
    class(model_t), intent(in) :: self
    logical, intent(out) :: used(:)
    used = .true.
  end subroutine reads_every_param

  !> xdot = f(t, x, u, p): the model's eval asked for f alone.
  pure subroutine point_f(self, t, x, u, p, xdot)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: xdot(:)
    integer :: none(0)
    call self%eval(t, x, u, p, none, xdot=xdot)
  end subroutine point_f

  !> y = h(t, x, u, p), without bias.
  pure subroutine point_h(self, t, x, u, p, y)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: y(:)
    integer :: none(0)
    call self%eval(t, x, u, p, none, y=y)
  end subroutine point_h

  !> a = df/dx (nx, nx).
  pure subroutine point_dfdx(self, t, x, u, p, a)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: a(:, :)
    integer :: none(0)
    call self%eval(t, x, u, p, none, a=a)
  end subroutine point_dfdx

  !> b(:, k) = df/dp(idx(k)).
  pure subroutine point_dfdp(self, t, x, u, p, idx, b)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: b(:, :)
    call self%eval(t, x, u, p, idx, b=b)
  end subroutine point_dfdp

  !> c = dh/dx (ny, nx).
  pure subroutine point_dhdx(self, t, x, u, p, c)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: c(:, :)
    integer :: none(0)
    call self%eval(t, x, u, p, none, c=c)
  end subroutine point_dhdx

  !> d(:, k) = dh/dp(idx(k)).
  pure subroutine point_dhdp(self, t, x, u, p, idx, d)
    class(model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: d(:, :)
    call self%eval(t, x, u, p, idx, d=d)
  end subroutine point_dhdp

  !> The blocks of theta for a model, on a record of one segment or of the
  !> segments starting at the samples seg.
  pure function model_layout(m, seg) result(l)
    class(model_t), intent(in) :: m
    integer, intent(in), optional :: seg(:)
    type(layout_t) :: l
    l%seg = [1]
    if (present(seg)) l%seg = seg
    l%nseg = size(l%seg)
    l%np = m%np
    l%nx = m%nx
    l%ny = m%ny
    l%nw = m%nw
    l%ox0 = m%np
    l%obias = l%ox0 + m%nx*l%nseg
    l%oq = l%obias + m%ny*l%nseg
    l%or = l%oq + m%nw
    l%os = l%or + m%ny
    l%odelay = l%os + m%nw*m%ny
    l%oudelay = l%odelay + m%ny
    l%nu = m%nu
    l%ostab = l%oudelay + m%nu
    l%op0 = l%ostab + m%nx*m%ny
    l%nth = l%op0 + m%nx
  end function model_layout

  !> Input j as the aircraft sees it: v_j = u_j + K(j, :) x (the recorded
  !> u_j alone when K = 0); one at a time, so nothing is allocated per call.
  pure real(wp) function surface(self, x, u, p, j) result(v)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    integer, intent(in) :: j
    integer :: s
    v = u(j)
    do s = 1, self%nx
      v = v + p(self%ok + (s - 1)*self%nu + j)*x(s)
    end do
  end function surface

  !> The linear model at one point (model_t%eval): each quantity is a
  !> block of p or a product with x and v, nothing is shared.
  pure subroutine lin_eval(self, t, x, u, p, idx, xdot, a, b, y, c, d)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(self%nx), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out), optional :: xdot(self%nx), a(self%nx, self%nx), b(self%nx, size(idx)), &
                                       y(self%ny), c(self%ny, self%nx), d(self%ny, size(idx))
    if (present(xdot)) call lin_f(self, x, u, p, xdot)
    if (present(a)) call block_plus_feedback(self, p, self%of, self%og, self%nx, a)   ! F + G K
    if (present(b)) call lin_dfdp(self, x, u, p, idx, b)
    if (present(y)) call lin_h(self, x, u, p, y)
    if (present(c)) call block_plus_feedback(self, p, self%oh, self%od, self%ny, c)   ! H + D K
    if (present(d)) call lin_dhdp(self, x, u, p, idx, d)
  end subroutine lin_eval

  !> a = the nr x nc block of p after offset o, plus B K when the model
  !> feeds states back (B the nr x nu block after ob, K p's feedback block);
  !> column by column, without temporaries (this runs at every RK4 stage).
  pure subroutine block_plus_feedback(self, p, o, ob, nr, a)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: p(:)
    integer, intent(in) :: o, ob, nr
    real(wp), intent(out) :: a(:, :)
    real(wp) :: bk
    integer :: i, j, s, nu
    nu = self%nu
    do j = 1, size(a, 2)
      a(:, j) = p(o + (j - 1)*nr + 1:o + j*nr)
    end do
    if (nu == 0) return
    if (all(p(self%ok + 1:self%ok + nu*self%nx) == 0.0_wp)) return
    do j = 1, size(a, 2)
      do i = 1, nr
        bk = 0.0_wp
        do s = 1, nu
          bk = bk + p(ob + (s - 1)*nr + i)*p(self%ok + (j - 1)*nu + s)
        end do
        a(i, j) = a(i, j) + bk
      end do
    end do
  end subroutine block_plus_feedback

  pure logical function lin_input_jacobians(self)
    class(linear_model_t), intent(in) :: self
    lin_input_jacobians = .true.
  end function lin_input_jacobians

  !> df/du = G (the feedback K x adds to u, not to its derivative).
  pure subroutine lin_dfdu(self, t, x, u, p, b)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: b(:, :)
    b = reshape(p(self%og + 1:self%og + self%nx*self%nu), [self%nx, self%nu])
  end subroutine lin_dfdu

  !> dh/du = D.
  pure subroutine lin_dhdu(self, t, x, u, p, b)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: b(:, :)
    b = reshape(p(self%od + 1:self%od + self%ny*self%nu), [self%ny, self%nu])
  end subroutine lin_dhdu

  pure subroutine lin_f(self, x, u, p, xdot)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    real(wp), intent(out) :: xdot(:)
    integer :: j, n
    n = self%nx
    xdot = 0.0_wp
    do j = 1, n
      xdot = xdot + p(self%of + (j - 1)*n + 1:self%of + j*n)*x(j)
    end do
    do j = 1, self%nu
      xdot = xdot + p(self%og + (j - 1)*n + 1:self%og + j*n)*surface(self, x, u, p, j)
    end do
    do j = 1, min(self%nw, size(u) - self%nu)          ! process noise, if given
      xdot = xdot + p(self%ogam + (j - 1)*n + 1:self%ogam + j*n)*u(self%nu + j)
    end do
    xdot = xdot + p(self%obx + 1:self%obx + n)
  end subroutine lin_f

  pure subroutine lin_h(self, x, u, p, y)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    real(wp), intent(out) :: y(:)
    integer :: j, m
    m = self%ny
    y = 0.0_wp
    do j = 1, self%nx
      y = y + p(self%oh + (j - 1)*m + 1:self%oh + j*m)*x(j)
    end do
    do j = 1, self%nu
      y = y + p(self%od + (j - 1)*m + 1:self%od + j*m)*surface(self, x, u, p, j)
    end do
  end subroutine lin_h

  pure subroutine lin_dfdp(self, x, u, p, idx, b)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: b(:, :)
    integer :: k, q, i, j, n
    n = self%nx
    b = 0.0_wp
    do k = 1, size(idx)
      q = idx(k)
      if (q <= self%og) then            ! F(i, j): df_i/dF(i, j) = x_j
        q = q - self%of - 1
        i = mod(q, n) + 1
        j = q/n + 1
        b(i, k) = x(j)
      else if (q <= self%oh) then       ! G(i, j): df_i/dG(i, j) = v_j
        q = q - self%og - 1
        i = mod(q, n) + 1
        j = q/n + 1
        b(i, k) = surface(self, x, u, p, j)
      else if (q > self%ogam .and. q <= self%ok) then  ! Gamma(i, j): df_i/dGamma(i, j) = w_j
        q = q - self%ogam - 1
        i = mod(q, n) + 1
        j = q/n + 1
        if (self%nu + j <= size(u)) b(i, k) = u(self%nu + j)
      else if (q > self%ok .and. q <= self%obx) then  ! K(j, s): df/dK(j, s) = G(:, j) x_s
        q = q - self%ok - 1
        j = mod(q, self%nu) + 1
        i = q/self%nu + 1
        b(:, k) = p(self%og + (j - 1)*n + 1:self%og + j*n)*x(i)
      else if (q > self%obx) then       ! bx(i): df_i/dbx(i) = 1
        b(q - self%obx, k) = 1.0_wp
      end if                            ! H and D do not enter f
    end do
  end subroutine lin_dfdp

  pure subroutine lin_dhdp(self, x, u, p, idx, d)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: d(:, :)
    integer :: k, q, i, j, m
    m = self%ny
    d = 0.0_wp
    do k = 1, size(idx)
      q = idx(k)
      if (q > self%oh .and. q <= self%od) then    ! H(i, j): dh_i/dH(i, j) = x_j
        q = q - self%oh - 1
        i = mod(q, m) + 1
        j = q/m + 1
        d(i, k) = x(j)
      else if (q > self%od .and. q <= self%ogam) then  ! D(i, j): dh_i/dD(i, j) = v_j
        q = q - self%od - 1
        i = mod(q, m) + 1
        j = q/m + 1
        d(i, k) = surface(self, x, u, p, j)
      else if (q > self%ok .and. q <= self%obx) then  ! K(j, s): dh/dK(j, s) = D(:, j) x_s
        q = q - self%ok - 1
        j = mod(q, self%nu) + 1
        i = q/self%nu + 1
        d(:, k) = p(self%od + (j - 1)*m + 1:self%od + j*m)*x(i)
      end if
    end do
  end subroutine lin_dhdp

  pure subroutine lin_dfdw(self, t, x, u, p, g)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    real(wp), intent(out) :: g(:, :)
    integer :: j, n
    n = self%nx
    do j = 1, self%nw
      g(:, j) = p(self%ogam + (j - 1)*n + 1:self%ogam + j*n)
    end do
  end subroutine lin_dfdw

  !> d(H + D K)/dp: H(i, j) gives e_i e_j', D(i, j) gives e_i K(j, :),
  !> K(j, s) gives D(:, j) e_s'.
  pure subroutine lin_dhdxp(self, t, x, u, p, idx, dc)
    class(linear_model_t), intent(in) :: self
    real(wp), intent(in) :: t, x(:), u(:), p(:)
    integer, intent(in) :: idx(:)
    real(wp), intent(out) :: dc(:, :, :)
    integer :: k, q, i, j, m, nu
    m = self%ny
    nu = self%nu
    dc = 0.0_wp
    do k = 1, size(idx)
      q = idx(k)
      if (q > self%oh .and. q <= self%od) then    ! H(i, j)
        q = q - self%oh - 1
        dc(mod(q, m) + 1, q/m + 1, k) = 1.0_wp
      else if (q > self%od .and. q <= self%ogam) then  ! D(i, j)
        q = q - self%od - 1
        i = mod(q, m) + 1
        j = q/m + 1
        dc(i, :, k) = p(self%ok + j:self%ok + nu*self%nx:nu)
      else if (q > self%ok .and. q <= self%obx) then  ! K(j, s)
        q = q - self%ok - 1
        j = mod(q, nu) + 1
        i = q/nu + 1
        dc(:, i, k) = p(self%od + (j - 1)*m + 1:self%od + j*m)
      end if
    end do
  end subroutine lin_dhdxp

end module mlid_models
