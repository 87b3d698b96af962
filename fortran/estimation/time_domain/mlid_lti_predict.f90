!> Output-error prediction of a linear time-invariant model (linear_model_t)
!> as linear maps, the fast path of mlid_filter's oe_manoeuvre.
!>
!> With F, G, H, D (and the feedback K) constant over a record and the input
!> linear between samples (or held), one RK4 step of length h of
!> xdot = A x + B u + b, A = F + G K, B = G, b = bx, is itself linear:
!>
!>   x+ = P x + Ea B u_a + Eb B u_b + (Ea + Eb) b,   M = h A,
!>   P  = I + M + M^2/2 + M^3/6 + M^4/24,
!>   Ea = h (I/2 + M/3 + M^2/8 + M^3/24),  Eb = h (I/2 + M/6 + M^2/24)
!>
!> (u_a, u_b the inputs at the step's ends, the mid-step stages taking their
!> mean), and nsub steps make the sample interval's map
!>
!>   x(j+1) = Phi x(j) + Gam0 u(j) + Gam1 u(j+1) + c.
!>
!> This is the RK4 polynomial, not expm: the states equal those of mlid_rk
!> up to rounding.  The sensitivity equations the RK4 path integrates with
!> the state form, with it, the linear system [x; s_k] of matrix
!> [A, 0; dA_k, A], whose RK4 step is the same polynomial, with the
!> partials of the map above (product rule) in its lower blocks: so the
!> partials dPhi_k, dGam0_k, dGam1_k, dc_k give the RK4 path's sensitivities
!> up to rounding.  States then follow by the recursion above; the forcing
!> of the sensitivities, s(j+1) = Phi s(j) + dPhi x(j) + dGam0 u(j) +
!> dGam1 u(j+1) + dc, and the outputs y = C x + D u + bias, dy = C s + dC x
!> + dD u + dbias (C = H + D K) are small matrix products, taken sample by
!> sample: the matrices are a few rows deep (nx, ny, nx nf), too few for
!> BLAS (the reference dgemm took twice the instructions, callgrind, the C-8
!> Monte Carlo) or for the compiler's loops over blocks of samples (their
!> overhead per column outweighed the arithmetic).  The sums go a few at a
!> time in vector registers (the states of a sample or a column, the rows
!> of C s, the forcing's rows); every sum keeps its terms' order, so the
!> results are the same to the bit as the products' were.
module mlid_lti_predict
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_DIVERGED, MLID_ERR_INTERRUPTED, MLID_ERR_MEMORY
  use mlid_interrupt, only: interrupt_requested, POLL_MASK
  use mlid_models, only: model_t, linear_model_t
  use mlid_options, only: options_t
  use mlid_params, only: param_map_t, input_delays, output_delays, stabilized
  implicit none
  private
  public :: lti_exact, lti_segment

  !> Rows of C s summed at a time (in registers).
  integer, parameter :: STRIP = 4
  !> States whose sums advance keeps in registers at a time.
  integer, parameter :: GROUP = 4
  !> Rows of the forcing summed at a time.
  integer, parameter :: FROWS = 8

  !> The model's matrices at theta and their partials by free column.
  type :: lti_sys_t
    real(wp), allocatable :: a(:, :), b(:, :), bx(:), c(:, :), d(:, :)
    real(wp), allocatable :: da(:, :, :), db(:, :, :), dbx(:, :), dc(:, :, :), dd(:, :, :)
    logical, allocatable :: moves(:)    !< column k moves the state equation
    !> The non-zero entries of dC_k and dD_k (few: one per free H or D entry):
    !> term t adds cv(t) x(cl(t)) to dy(ci(t), ck(t)), du likewise with u.
    integer, allocatable :: ci(:), ck(:), cl(:), di(:), dk(:), dl(:)
    real(wp), allocatable :: cv(:), dv(:)
  end type lti_sys_t

  !> One RK4 step's polynomials in M = h A (P the state's, Ea and Eb the
  !> step's first and last input's) and the interval's map after each of
  !> its nsub steps (index 0: none), with the steps' input fractions.
  type :: step_t
    real(wp), allocatable :: m(:, :), m2(:, :), m3(:, :), p(:, :), ea(:, :), eb(:, :)
    real(wp), allocatable :: phi(:, :, :), g0(:, :, :), g1(:, :, :), c(:, :), fa(:), fb(:)
  end type step_t

  !> The sample interval's map and its partials by live column c:
  !> w(:, c, :) = [dPhi_c, dGam0_c, dGam1_c] and dc(:, c) = dc_c (zero for a
  !> column that moves only x0).
  type :: lti_map_t
    real(wp), allocatable :: phi(:, :), g0(:, :), g1(:, :), c(:)
    real(wp), allocatable :: w(:, :, :), dc(:, :)
  end type lti_map_t

contains

  !> Whether lti_segment gives samples j0..j1 exactly (up to rounding): a
  !> linear_model_t, no input or output delays, no stabilized output error,
  !> and samples evenly spaced (to the rounding of times t0 + k dt).
  logical function lti_exact(m, theta, pm, t, j0, j1)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: j0, j1
    real(wp) :: dt, tol
    lti_exact = .false.
    select type (m)
    type is (linear_model_t)
      if (input_delays(theta, pm) .or. output_delays(theta, pm)) return
      if (stabilized(theta, pm%l) .or. size(pm%ik) > 0) return
      if (j1 > j0) then
        dt = (t(j1) - t(j0))/(j1 - j0)
        tol = 16*epsilon(1.0_wp)*max(abs(t(j0)), abs(t(j1)), dt)
        if (any(abs((t(j0 + 1:j1) - t(j0:j1 - 1)) - dt) > tol)) return
      end if
      lti_exact = .true.
    end select
  end function lti_exact

  !> oe_segment's outputs yhat(:, j0:j1) of segment iseg, and dy(:, :, j0:j1)
  !> and xhist(:, j0:j1) if present, for a model lti_exact accepts.  s0: the
  !> segment's initial sensitivities (nx, nf).  A state that is not finite
  !> returns MLID_ERR_DIVERGED and nothing else: the caller's RK4 path then
  !> says where, as it always has; a Ctrl-C, MLID_ERR_INTERRUPTED; no memory
  !> for the states, MLID_ERR_MEMORY.
  subroutine lti_segment(m, theta, pm, t, u, opt, iseg, j0, j1, s0, yhat, status, dy, xhist)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :), s0(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    integer, intent(in) :: iseg, j0, j1
    real(wp), intent(inout) :: yhat(:, :)
    integer, intent(out) :: status
    real(wp), intent(inout), optional :: dy(:, :, :), xhist(:, :)
    type(lti_sys_t) :: sys
    type(lti_map_t) :: mp
    real(wp), allocatable :: x(:, :)
    integer, allocatable :: live(:)
    real(wp) :: dt
    integer :: n, nx, nu, ny, j

    status = MLID_OK
    n = j1 - j0 + 1
    nx = m%nx
    nu = m%nu
    ny = m%ny
    dt = 0.0_wp
    if (n > 1) dt = (t(j1) - t(j0))/(n - 1)
    select type (m)
    type is (linear_model_t)
      call system_of(m, theta(1:pm%l%np), pm, present(dy), sys)
    end select
    if (present(dy)) then   ! the columns with states' sensitivities: moving f, or x0
      live = pack([(j, j=1, pm%nf)], sys%moves .or. [(any(s0(:, j) /= 0.0_wp), j=1, pm%nf)])
      call interval_map(sys, dt, opt%substeps, opt%hold, mp, live)
    else
      call interval_map(sys, dt, opt%substeps, opt%hold, mp)
    end if
    allocate (x(nx, n), stat=j)
    if (j /= 0) then                    ! the caller names it (mlid_filter, mlid_simulate)
      status = MLID_ERR_MEMORY
      return
    end if
    x(:, 1) = theta(pm%l%ox0 + (iseg - 1)*nx + 1:pm%l%ox0 + iseg*nx)
    select case (nx)                    ! the common sizes as constants: loops unrolled
    case (1)
      call states(1, nu, n, opt%hold, mp%phi, mp%g0, mp%g1, mp%c, u(:, j0:j1), x)
    case (2)
      call states(2, nu, n, opt%hold, mp%phi, mp%g0, mp%g1, mp%c, u(:, j0:j1), x)
    case (3)
      call states(3, nu, n, opt%hold, mp%phi, mp%g0, mp%g1, mp%c, u(:, j0:j1), x)
    case (4)
      call states(4, nu, n, opt%hold, mp%phi, mp%g0, mp%g1, mp%c, u(:, j0:j1), x)
    case default
      call states(nx, nu, n, opt%hold, mp%phi, mp%g0, mp%g1, mp%c, u(:, j0:j1), x)
    end select
    if (.not. all(ieee_is_finite(x))) then
      status = MLID_ERR_DIVERGED
      return
    end if
    if (interrupt_requested()) then
      status = MLID_ERR_INTERRUPTED
      return
    end if
    if (present(xhist)) xhist(:, j0:j1) = x
    call outputs(ny, nx, nu, n, sys%c, sys%d, &
                 theta(pm%l%obias + (iseg - 1)*ny + 1:pm%l%obias + iseg*ny), x, u(:, j0:j1), &
                 yhat(:, j0:j1))
    if (present(dy)) call sensitivities(ny, nx, nu, pm%nf, n, size(live), live, pm, iseg, sys, &
                                        mp, opt%hold, x, u(:, j0:j1), s0(:, live), &
                                        dy(:, :, j0:j1), status)
  end subroutine lti_segment

  !> The states x(:, 2:n) from x(:, 1), sample by sample:
  !> x(j) = (((0 + Gam0 u(j-1)) + Gam1 u(j)) + c) + Phi x(j-1), each
  !> product's terms in order (the order of the products over the record
  !> before).  Up to GROUP states as one vector sum (a constant nx: in
  !> registers), more state by state.
  pure subroutine states(nx, nu, n, hold, phi, g0, g1, c, u, x)
    integer, value :: nx                ! by value: a constant nx makes a clone
    integer, intent(in) :: nu, n
    logical, intent(in) :: hold
    real(wp), intent(in) :: phi(nx, nx), g0(nx, nu), g1(nx, nu), c(nx), u(nu, n)
    real(wp), intent(inout) :: x(nx, n)
    real(wp) :: a, v(GROUP)
    integer :: i, j, l

    if (nx <= GROUP) then
      do j = 2, n
        v = 0.0_wp
        !GCC$ novector
        do l = 1, nu
          v(1:nx) = v(1:nx) + g0(:, l)*u(l, j - 1)
        end do
        if (.not. hold) then
          !GCC$ novector
          do l = 1, nu
            v(1:nx) = v(1:nx) + g1(:, l)*u(l, j)
          end do
        end if
        v(1:nx) = v(1:nx) + c
        !GCC$ novector
        do l = 1, nx
          v(1:nx) = v(1:nx) + phi(:, l)*x(l, j - 1)
        end do
        x(:, j) = v(1:nx)
      end do
      return
    end if
    do j = 2, n
      do i = 1, nx
        a = 0.0_wp
        !GCC$ novector
        do l = 1, nu
          a = a + g0(i, l)*u(l, j - 1)
        end do
        if (.not. hold) then
          !GCC$ novector
          do l = 1, nu
            a = a + g1(i, l)*u(l, j)
          end do
        end if
        a = a + c(i)
        !GCC$ novector
        do l = 1, nx
          a = a + phi(i, l)*x(l, j - 1)
        end do
        x(i, j) = a
      end do
    end do
  end subroutine states

  !> The outputs y = ((0 + C x) + D u) + bias of n samples (each product's
  !> terms in order), STRIP rows of every sample at a time (the strip's sums
  !> in registers), then the rows left one by one.
  pure subroutine outputs(ny, nx, nu, n, cm, dm, bias, x, u, y)
    integer, intent(in) :: ny, nx, nu, n
    real(wp), intent(in) :: cm(ny, nx), dm(ny, nu), bias(ny), x(nx, n), u(nu, n)
    real(wp), intent(inout) :: y(ny, n)
    real(wp) :: acc(STRIP), a
    integer :: i, j, l, last

    last = ny - mod(ny, STRIP)
    do i = 1, last, STRIP
      do j = 1, n
        acc = 0.0_wp
        !GCC$ novector
        do l = 1, nx
          acc = acc + cm(i:i + STRIP - 1, l)*x(l, j)
        end do
        !GCC$ novector
        do l = 1, nu
          acc = acc + dm(i:i + STRIP - 1, l)*u(l, j)
        end do
        y(i:i + STRIP - 1, j) = acc + bias(i:i + STRIP - 1)
      end do
    end do
    do i = last + 1, ny
      do j = 1, n
        a = 0.0_wp
        !GCC$ novector
        do l = 1, nx
          a = a + cm(i, l)*x(l, j)
        end do
        !GCC$ novector
        do l = 1, nu
          a = a + dm(i, l)*u(l, j)
        end do
        y(i, j) = a + bias(i)
      end do
    end do
  end subroutine outputs

  !> dy(ny, nf, n) (as dy(ny nf, n)) over n samples, sample by sample.  The states'
  !> sensitivities of the live columns live(1:nl) (the others' dy hold
  !> only their dC x, dD u and dbias terms) start from s0 (nx, nl), s(:, c)
  !> column c's: advanced by the recursion with its forcing (advance), then
  !> dy = C s (c_times_s) + the few terms of dC x and dD u + dbias.  Each element sums its terms in the order the products over
  !> blocks of samples did before, so the results are those to the bit.
  subroutine sensitivities(ny, nx, nu, nf, n, nl, live, pm, iseg, sys, mp, hold, x, u, s0, dy, &
                           status)
    integer, intent(in) :: ny, nx, nu, nf, n, nl, live(nl), iseg
    type(param_map_t), intent(in) :: pm
    type(lti_sys_t), intent(in) :: sys
    type(lti_map_t), intent(in) :: mp
    logical, intent(in) :: hold
    real(wp), intent(in) :: x(nx, n), u(nu, n), s0(nx, nl)
    real(wp), intent(out) :: dy(ny*nf, n)
    integer, intent(inout) :: status     !< MLID_ERR_INTERRUPTED on a Ctrl-C
    real(wp) :: wb(size(pm%ib))
    integer(int64) :: off(nl)            ! 64-bit: no widening at each use
    integer :: oc(size(sys%cv)), od(size(sys%dv)), ob(size(pm%ib)), nb, k, i, z0, z1

    off = (live - 1)*ny                 ! dy(i, live(c)) is dy(off(c) + i)
    oc = sys%ci + (sys%ck - 1)*ny       ! the dC, dD terms' places in dy(:, k)
    od = sys%di + (sys%dk - 1)*ny
    nb = 0                              ! the segment's free biases
    do k = 1, size(pm%ib)
      i = pm%ib(k) - (iseg - 1)*ny
      if (i < 1 .or. i > ny) cycle
      nb = nb + 1
      ob(nb) = i + (pm%cb(k) - 1)*ny
      wb(nb) = pm%wb(k)
    end do
    z0 = 1                              ! dy(z0:z1, k) spans the columns C s does not write
    z1 = 0                              ! (live ascending: the first and last not in it)
    if (nl < nf) then
      i = 0
      do k = 1, nl
        if (live(k) == k) i = k
      end do
      z0 = i*ny + 1
      i = nl + 1
      do k = nl, 1, -1
        if (live(k) == nf - nl + k) i = k
      end do
      z1 = (nf - (nl + 1 - i))*ny
    end if
    select case (nx)                    ! the common sizes as constants: loops unrolled
    case (1)
      call sweep(1, ny, nu, nf, n, nl, hold, off, oc, od, ob(1:nb), wb(1:nb), &
                 z0, z1, sys, mp%w, mp%dc, mp%phi, sys%c, x, u, s0, dy, status)
    case (2)
      call sweep(2, ny, nu, nf, n, nl, hold, off, oc, od, ob(1:nb), wb(1:nb), &
                 z0, z1, sys, mp%w, mp%dc, mp%phi, sys%c, x, u, s0, dy, status)
    case (3)
      call sweep(3, ny, nu, nf, n, nl, hold, off, oc, od, ob(1:nb), wb(1:nb), &
                 z0, z1, sys, mp%w, mp%dc, mp%phi, sys%c, x, u, s0, dy, status)
    case (4)
      call sweep(4, ny, nu, nf, n, nl, hold, off, oc, od, ob(1:nb), wb(1:nb), &
                 z0, z1, sys, mp%w, mp%dc, mp%phi, sys%c, x, u, s0, dy, status)
    case default
      call sweep(nx, ny, nu, nf, n, nl, hold, off, oc, od, ob(1:nb), wb(1:nb), &
                 z0, z1, sys, mp%w, mp%dc, mp%phi, sys%c, x, u, s0, dy, status)
    end select
  end subroutine sensitivities

  !> sensitivities' sample loop (nx by value: a constant nx makes a clone),
  !> s(:, :, now) the sensitivities at sample k.
  subroutine sweep(nx, ny, nu, nf, n, nl, hold, off, oc, od, ob, wb, z0, z1, sys, w, dc, &
                   phi, cm, x, u, s0, dy, status)
    integer, value :: nx
    integer, intent(in) :: ny, nu, nf, n, nl, oc(:), od(:), ob(:), z0, z1
    integer(int64), intent(in) :: off(nl)
    logical, intent(in) :: hold
    real(wp), intent(in) :: wb(:), w(nx, nl, nx + 2*nu), dc(nx, nl), phi(nx, nx), cm(ny, nx), &
                            x(nx, n), u(nu, n), s0(nx, nl)
    type(lti_sys_t), intent(in) :: sys
    real(wp), intent(inout) :: dy(ny*nf, n)
    integer, intent(inout) :: status
    real(wp) :: s(nx, nl, 2), zb(GROUP, nx + 2*nu)
    integer :: k, t, now, nz

    nz = nx + 2*nu                      ! the forcing's columns (u1 none when held)
    if (hold) nz = nx + nu
    s(:, :, 1) = s0
    now = 1
    do k = 1, n
      if (iand(k, POLL_MASK) == 0) then
        if (interrupt_requested()) then
          status = MLID_ERR_INTERRUPTED
          return
        end if
      end if
      if (k > 1) then                   ! s(k) from s(k-1) and the interval's forcing
        if (nx <= 2) then               ! z = [x0; u0; u1], each in every lane of a vector
          do t = 1, nx
            zb(:, t) = x(t, k - 1)
          end do
        end if
        do t = 1, nu
          zb(:, nx + t) = u(t, k - 1)
          zb(:, nx + nu + t) = u(t, k)
        end do
        call advance(nx, nz, nl, w, x(:, k - 1), zb, dc, phi, s(:, :, now), s(:, :, 3 - now))
        now = 3 - now
      end if
      dy(z0:z1, k) = 0.0_wp
      call c_times_s(nl, nx, ny, nf, off, cm, s(:, :, now), dy(:, k))
      do t = 1, size(oc)
        dy(oc(t), k) = dy(oc(t), k) + sys%cv(t)*x(sys%cl(t), k)
      end do
      do t = 1, size(od)
        dy(od(t), k) = dy(od(t), k) + sys%dv(t)*u(sys%dl(t), k)
      end do
      do t = 1, size(ob)
        dy(ob(t), k) = dy(ob(t), k) + wb(t)
      end do
    end do
  end subroutine sweep

  !> One interval of the sensitivities s(:, c) of the nl live columns:
  !> sn(i, c) = ((0 + sum_l w(i, c, l) z(l)) + dc(i, c)) + sum_l Phi(i, l) s(l, c),
  !> each sum's terms in order (z = [x0; u0; u1]: dPhi x, dGam0 u0, dGam1 u1;
  !> nz = nx + nu when held, u1 none; zb(:, l) holds z(l) in every lane).
  !> The sums stay in (vector) registers and have a fixed size (an
  !> automatic array would be allocated on the heap at every call).  One
  !> or two states: the forcing of all columns as one vector (rows
  !> i + nx (c - 1), GROUP at a time), then Phi s column by column; more:
  !> column by column, GROUP states at a time (callgrind, gcc 12: fewer
  !> instructions each way for those sizes).
  pure subroutine advance(nx, nz, nl, w, x0, zb, dc, phi, s, sn)
    integer, value :: nx                ! by value: a constant nx makes a clone
    integer, intent(in) :: nz, nl
    real(wp), intent(in) :: w(nx, nl, nz), x0(nx), zb(GROUP, nz), dc(nx, nl), phi(nx, nx), &
                            s(nx, nl)
    real(wp), intent(out) :: sn(nx, nl)
    real(wp) :: a(GROUP)
    integer :: c, l

    if (nx <= 2) then
      call forcing(nx*nl, nz, w, zb, dc, sn)
      do c = 1, nl
        a(1:nx) = sn(:, c)
        !GCC$ novector
        do l = 1, nx
          a(1:nx) = a(1:nx) + phi(:, l)*s(l, c)
        end do
        sn(:, c) = a(1:nx)
      end do
      return
    end if
    if (nx > GROUP) then
      call advance_wide(nx, nz, nl, w, x0, zb, dc, phi, s, sn)
      return
    end if
    do c = 1, nl                        ! one group (of a constant size in nx's clones)
      call advance_group(nx, 0, nx, nz, w(:, c, :), x0, zb, dc(:, c), phi, s(:, c), sn(:, c))
    end do
  end subroutine advance

  !> advance for more than GROUP states: whole groups, then the r states
  !> left (r made a constant).
  pure subroutine advance_wide(nx, nz, nl, w, x0, zb, dc, phi, s, sn)
    integer, intent(in) :: nx, nz, nl
    real(wp), intent(in) :: w(nx, nl, nz), x0(nx), zb(GROUP, nz), dc(nx, nl), phi(nx, nx), &
                            s(nx, nl)
    real(wp), intent(out) :: sn(nx, nl)
    integer :: c, g, r

    r = mod(nx, GROUP)
    do c = 1, nl
      do g = 0, nx - GROUP, GROUP
        call advance_group(GROUP, g, nx, nz, w(:, c, :), x0, zb, dc(:, c), phi, s(:, c), &
                           sn(:, c))
      end do
      select case (r)
      case (1)
        call advance_group(1, nx - 1, nx, nz, w(:, c, :), x0, zb, dc(:, c), phi, s(:, c), &
                           sn(:, c))
      case (2)
        call advance_group(2, nx - 2, nx, nz, w(:, c, :), x0, zb, dc(:, c), phi, s(:, c), &
                           sn(:, c))
      case (3)
        call advance_group(3, nx - 3, nx, nz, w(:, c, :), x0, zb, dc(:, c), phi, s(:, c), &
                           sn(:, c))
      end select
    end do
  end subroutine advance_wide

  !> advance's sums of states g+1..g+m of one column (m by value: a
  !> constant m makes a clone).
  pure subroutine advance_group(m, g, nx, nz, w, x0, zb, dc, phi, s, sn)
    integer, value :: m
    integer, intent(in) :: g, nx, nz
    real(wp), intent(in) :: w(:, :), x0(nx), zb(GROUP, nz), dc(nx), phi(nx, nx), s(nx)
    real(wp), intent(inout) :: sn(nx)
    real(wp) :: a(GROUP)
    integer :: l

    a = 0.0_wp
    !GCC$ novector
    do l = 1, nx
      a(1:m) = a(1:m) + w(g + 1:g + m, l)*x0(l)
    end do
    !GCC$ novector
    !GCC$ unroll 2
    do l = nx + 1, nz
      a(1:m) = a(1:m) + w(g + 1:g + m, l)*zb(1:m, l)
    end do
    a(1:m) = a(1:m) + dc(g + 1:g + m)
    !GCC$ novector
    do l = 1, nx
      a(1:m) = a(1:m) + phi(g + 1:g + m, l)*s(l)
    end do
    sn(g + 1:g + m) = a(1:m)
  end subroutine advance_group

  !> f(r) = (0 + sum_l w(r, l) z(l)) + dc(r) for the nr rows, FROWS at a
  !> time in pairs of lanes (each z(l) loaded once as a pair), then the
  !> rows left one by one.  nz is not a constant: the loop over l stays a
  !> loop and its sums vectors (gcc 12 left the sums of a loop it unrolled
  !> scalar; with the rows left in pairs, it split the main loop's pairs).
  pure subroutine forcing(nr, nz, w, zb, dc, f)
    integer, intent(in) :: nr, nz
    real(wp), intent(in) :: w(nr, nz), zb(GROUP, nz), dc(nr)
    real(wp), intent(out) :: f(nr)
    real(wp) :: a(FROWS), b
    integer :: r, l, last, q

    last = nr - mod(nr, FROWS)
    do r = 1, last, FROWS
      a = 0.0_wp
      !GCC$ novector
      do l = 1, nz
        do q = 0, FROWS - 2, 2
          a(q + 1:q + 2) = a(q + 1:q + 2) + w(r + q:r + q + 1, l)*zb(1:2, l)
        end do
      end do
      f(r:r + FROWS - 1) = a + dc(r:r + FROWS - 1)
    end do
    do r = last + 1, nr
      b = 0.0_wp
      do l = 1, nz
        b = b + w(r, l)*zb(1, l)
      end do
      f(r) = b + dc(r)
    end do
  end subroutine forcing

  !> dy(off(c) + i) = (C s)(i, c) for the nl live columns, its terms
  !> summed in order from 0: STRIP rows of every column at a time, then
  !> the rows left one by one.
  pure subroutine c_times_s(nl, nx, ny, nf, off, cm, s, dy)
    integer, intent(in) :: ny, nf, nl
    integer(int64), intent(in) :: off(nl)
    integer, value :: nx                ! by value: a constant nx makes a clone
    real(wp), intent(in) :: cm(ny, nx), s(nx, nl)
    real(wp), intent(inout) :: dy(ny*nf)
    real(wp) :: acc(STRIP), a
    integer :: c, i, l, last

    last = ny - mod(ny, STRIP)          ! the rows in whole strips
    do i = 1, last, STRIP               ! (C's strip reused over the columns)
      do c = 1, nl
        acc = 0.0_wp
        !GCC$ novector
        do l = 1, nx
          acc = acc + cm(i:i + STRIP - 1, l)*s(l, c)
        end do
        dy(off(c) + i:off(c) + i + STRIP - 1) = acc
      end do
    end do
    do i = last + 1, ny
      do c = 1, nl
        a = 0.0_wp
        do l = 1, nx
          a = a + cm(i, l)*s(l, c)
        end do
        dy(off(c) + i) = a
      end do
    end do
  end subroutine c_times_s

  !> A, B, b, C, D at the model parameters p and, with partials, their
  !> partials by free column (a tie adds its term's scale), read through the
  !> linear model's offsets, p = [vec F, vec G, vec H, vec D, vec Gamma,
  !> vec K, bx] (mlid_models), with the feedback K: A = F + G K, C = H + D K.
  subroutine system_of(m, p, pm, partials, sys)
    type(linear_model_t), intent(in) :: m
    real(wp), intent(in) :: p(:)
    type(param_map_t), intent(in) :: pm
    logical, intent(in) :: partials
    type(lti_sys_t), intent(out) :: sys
    real(wp) :: kf(m%nu, m%nx), f(m%nx, m%nx), h(m%ny, m%nx), w
    integer :: nx, nu, ny, nf, k, q, i, j, c

    nx = m%nx
    nu = m%nu
    ny = m%ny
    nf = pm%nf
    allocate (sys%b(nx, nu), sys%d(ny, nu))
    call m%matrices(p, f, sys%b, h, sys%d, kf)
    sys%a = f + matmul(sys%b, kf)
    sys%c = h + matmul(sys%d, kf)
    sys%bx = p(m%obx + 1:m%obx + nx)
    if (.not. partials) return
    ! dc(:, k, :) is dC_k and dd(:, k, :) dD_k (nonzeros lists their entries)
    allocate (sys%da(nx, nx, nf), sys%db(nx, nu, nf), sys%dbx(nx, nf), sys%dc(ny, nf, nx), &
              sys%dd(ny, nf, nu), sys%moves(nf))
    sys%da = 0.0_wp
    sys%db = 0.0_wp
    sys%dbx = 0.0_wp
    sys%dc = 0.0_wp
    sys%dd = 0.0_wp
    do k = 1, size(pm%im)
      q = pm%im(k)
      c = pm%cm(k)
      w = pm%wm(k)
      if (q <= m%og) then                          ! F(i, j)
        call ij(q - m%of, nx, i, j)
        sys%da(i, j, c) = sys%da(i, j, c) + w
      else if (q <= m%oh) then                     ! G(i, j): B, and A through K
        call ij(q - m%og, nx, i, j)
        sys%db(i, j, c) = sys%db(i, j, c) + w
        sys%da(i, :, c) = sys%da(i, :, c) + w*kf(j, :)
      else if (q <= m%od) then                     ! H(i, j)
        call ij(q - m%oh, ny, i, j)
        sys%dc(i, c, j) = sys%dc(i, c, j) + w
      else if (q <= m%ogam) then                   ! D(i, j): D, and C through K
        call ij(q - m%od, ny, i, j)
        sys%dd(i, c, j) = sys%dd(i, c, j) + w
        sys%dc(i, c, :) = sys%dc(i, c, :) + w*kf(j, :)
      else if (q > m%ok .and. q <= m%obx) then     ! K(j, i): G(:, j), D(:, j) in column i
        call ij(q - m%ok, nu, j, i)
        sys%da(:, i, c) = sys%da(:, i, c) + w*sys%b(:, j)
        sys%dc(:, c, i) = sys%dc(:, c, i) + w*sys%d(:, j)
      else if (q > m%obx) then                     ! bx(i)
        sys%dbx(q - m%obx, c) = sys%dbx(q - m%obx, c) + w
      end if                                       ! Gamma: no noise in output error
    end do
    call nonzeros(sys%dc, sys%ci, sys%ck, sys%cl, sys%cv)
    call nonzeros(sys%dd, sys%di, sys%dk, sys%dl, sys%dv)
    do k = 1, nf
      sys%moves(k) = any(sys%da(:, :, k) /= 0.0_wp) .or. any(sys%db(:, :, k) /= 0.0_wp) .or. &
                     any(sys%dbx(:, k) /= 0.0_wp)
    end do
  end subroutine system_of

  !> The non-zero entries a(i(t), k(t), l(t)) = v(t) of a.
  pure subroutine nonzeros(a, i, k, l, v)
    real(wp), intent(in) :: a(:, :, :)
    integer, allocatable, intent(out) :: i(:), k(:), l(:)
    real(wp), allocatable, intent(out) :: v(:)
    integer :: p, q, r, t
    t = count(a /= 0.0_wp)
    allocate (i(t), k(t), l(t), v(t))
    t = 0
    do r = 1, size(a, 3)
      do q = 1, size(a, 2)
        do p = 1, size(a, 1)
          if (a(p, q, r) == 0.0_wp) cycle
          t = t + 1
          i(t) = p
          k(t) = q
          l(t) = r
          v(t) = a(p, q, r)
        end do
      end do
    end do
  end subroutine nonzeros

  !> Row i and column j of entry q (from 1) of a column-major block of nr rows.
  pure subroutine ij(q, nr, i, j)
    integer, intent(in) :: q, nr
    integer, intent(out) :: i, j
    i = mod(q - 1, nr) + 1
    j = (q - 1)/nr + 1
  end subroutine ij

  !> The sample interval's map of sys (rk4_map) and, with partials, those
  !> of each column that moves the state equation by the product rule on
  !> the same polynomials: the partials of the discrete map the RK4 path's
  !> sensitivity equations integrate, up to rounding.
  subroutine interval_map(sys, dt, nsub, hold, mp, live)
    type(lti_sys_t), intent(in) :: sys
    real(wp), intent(in) :: dt
    integer, intent(in) :: nsub
    logical, intent(in) :: hold
    type(lti_map_t), intent(out) :: mp
    integer, intent(in), optional :: live(:)   !< the columns to give partials of
    type(step_t) :: st
    real(wp), dimension(size(sys%a, 1), size(sys%a, 1)) :: dm, dm2, dm3, dp, dea, deb, dphi
    real(wp), dimension(size(sys%b, 1), size(sys%b, 2)) :: deab, debb, dg0, dg1
    real(wp) :: dcb(size(sys%a, 1)), dc(size(sys%a, 1)), h
    integer :: nx, nu, nf, k, i, c
    logical :: da

    nx = size(sys%a, 1)
    nu = size(sys%b, 2)
    h = dt/nsub
    call rk4_map(sys%a, sys%b, sys%bx, h, nsub, hold, st, mp%phi, mp%g0, mp%g1, mp%c)
    if (.not. present(live)) return
    nf = size(live)
    allocate (mp%w(nx, nf, nx + 2*nu), mp%dc(nx, nf))
    mp%w = 0.0_wp
    mp%dc = 0.0_wp
    do c = 1, nf
      k = live(c)
      if (.not. sys%moves(k)) cycle
      da = any(sys%da(:, :, k) /= 0.0_wp)
      dp = 0.0_wp
      dea = 0.0_wp
      deb = 0.0_wp
      if (da) then                       ! d(M^n) = d(M^(n-1)) M + M^(n-1) dM
        dm = h*sys%da(:, :, k)
        dm2 = matmul(dm, st%m) + matmul(st%m, dm)
        dm3 = matmul(dm2, st%m) + matmul(st%m2, dm)
        dp = dm + dm2/2.0_wp + dm3/6.0_wp + (matmul(dm3, st%m) + matmul(st%m3, dm))/24.0_wp
        dea = h*(dm/3.0_wp + dm2/8.0_wp + dm3/24.0_wp)
        deb = h*(dm/6.0_wp + dm2/24.0_wp)
      end if
      deab = matmul(dea, sys%b) + matmul(st%ea, sys%db(:, :, k))
      debb = matmul(deb, sys%b) + matmul(st%eb, sys%db(:, :, k))
      dcb = matmul(dea + deb, sys%bx) + matmul(st%ea + st%eb, sys%dbx(:, k))
      dphi = dp                          ! the first step (from phi = I, g0 = g1 = c = 0)
      dg0 = (1.0_wp - st%fa(1))*deab + (1.0_wp - st%fb(1))*debb
      dg1 = st%fa(1)*deab + st%fb(1)*debb
      dc = dcb
      do i = 2, nsub                     ! the product rule on rk4_map's recursion
        dphi = matmul(dp, st%phi(:, :, i - 1)) + matmul(st%p, dphi)
        dg0 = matmul(dp, st%g0(:, :, i - 1)) + matmul(st%p, dg0) + &
              (1.0_wp - st%fa(i))*deab + (1.0_wp - st%fb(i))*debb
        dg1 = matmul(dp, st%g1(:, :, i - 1)) + matmul(st%p, dg1) + st%fa(i)*deab + st%fb(i)*debb
        dc = matmul(dp, st%c(:, i - 1)) + matmul(st%p, dc) + dcb
      end do
      mp%w(:, c, 1:nx) = dphi
      mp%w(:, c, nx + 1:nx + nu) = dg0
      mp%w(:, c, nx + nu + 1:) = dg1
      mp%dc(:, c) = dc
    end do
  end subroutine interval_map

  !> nsub RK4 steps of length h of xdot = a x + b u + bx, u linear over the
  !> interval from u0 to u1 (held at u0 when hold): the interval's map
  !> x(nsub h) = phi x(0) + g0 u0 + g1 u1 + c, and in st the step's
  !> polynomials and the map after each step (for the partials).
  subroutine rk4_map(a, b, bx, h, nsub, hold, st, phi, g0, g1, c)
    real(wp), intent(in) :: a(:, :), b(:, :), bx(:), h
    integer, intent(in) :: nsub
    logical, intent(in) :: hold
    type(step_t), intent(out) :: st
    real(wp), allocatable, intent(out) :: phi(:, :), g0(:, :), g1(:, :), c(:)
    real(wp), dimension(size(a, 1), size(a, 1)) :: eye
    real(wp), dimension(size(b, 1), size(b, 2)) :: eab, ebb
    real(wp) :: cb(size(a, 1))
    integer :: n, nu, i

    n = size(a, 1)
    nu = size(b, 2)
    eye = 0.0_wp
    do i = 1, n
      eye(i, i) = 1.0_wp
    end do
    st%m = h*a
    st%m2 = matmul(st%m, st%m)
    st%m3 = matmul(st%m2, st%m)
    st%p = eye + st%m + st%m2/2.0_wp + st%m3/6.0_wp + matmul(st%m3, st%m)/24.0_wp
    st%ea = h*(eye/2.0_wp + st%m/3.0_wp + st%m2/8.0_wp + st%m3/24.0_wp)  ! the step's first input
    st%eb = h*(eye/2.0_wp + st%m/6.0_wp + st%m2/24.0_wp)                 ! and its last
    eab = matmul(st%ea, b)
    ebb = matmul(st%eb, b)
    cb = matmul(st%ea + st%eb, bx)
    allocate (st%phi(n, n, 0:nsub), st%g0(n, nu, 0:nsub), st%g1(n, nu, 0:nsub), st%c(n, 0:nsub), &
              st%fa(nsub), st%fb(nsub))
    st%phi(:, :, 0) = eye
    st%g0(:, :, 0) = 0.0_wp
    st%g1(:, :, 0) = 0.0_wp
    st%c(:, 0) = 0.0_wp
    do i = 1, nsub
      st%fa(i) = 0.0_wp                  ! the step's ends in the interval, as rk4_interval's
      st%fb(i) = 0.0_wp
      if (.not. hold) then
        st%fa(i) = real(i - 1, wp)/nsub
        st%fb(i) = real(i, wp)/nsub
      end if
      st%phi(:, :, i) = matmul(st%p, st%phi(:, :, i - 1))
      st%g0(:, :, i) = matmul(st%p, st%g0(:, :, i - 1)) + (1.0_wp - st%fa(i))*eab + &
                       (1.0_wp - st%fb(i))*ebb
      st%g1(:, :, i) = matmul(st%p, st%g1(:, :, i - 1)) + st%fa(i)*eab + st%fb(i)*ebb
      st%c(:, i) = matmul(st%p, st%c(:, i - 1)) + cb
    end do
    phi = st%phi(:, :, nsub)
    g0 = st%g0(:, :, nsub)
    g1 = st%g1(:, :, nsub)
    c = st%c(:, nsub)
  end subroutine rk4_map

end module mlid_lti_predict
