!> The parameter map: which entries of theta are free, which are tied to
!> others by affine ties
!>   theta(k) := c(k) + sum over its terms of s * theta(j)
!> (an equality tie is one term with s = 1, c = 0), and to which block each
!> moving entry belongs.  Sensitivities are kept per free parameter; a
!> tied entry adds its effect, times the term's scale, to the column of
!> each free parameter it follows.
module mlid_params
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: layout_t
  implicit none
  private
  public :: param_map_t, tie_t, ties_of, param_map_create, free_indices, manoeuvre_places, &
            segment_map, apply_ties, &
            no_ties, input_delays, output_delays, stabilized

  !> Affine ties: term i gives theta(to(i)) the part scale(i)*theta(from(i));
  !> offset(k) is the constant of a tied entry k (0 for the others).
  type :: tie_t
    integer, allocatable :: to(:), from(:)
    real(wp), allocatable :: scale(:), offset(:)
  end type tie_t

  type :: param_map_t
    type(layout_t) :: l
    integer :: nf = 0
    integer, allocatable :: ifree(:)            !< theta index of each free parameter
    type(tie_t) :: tie
    !> Moving entries by block: the index within the block, the free column
    !> and the weight (1 for a free entry, the term's scale for a tied one).
    integer, allocatable :: im(:), cm(:)        !< model parameters p
    integer, allocatable :: ix0(:), cx0(:)      !< initial states (segment by segment)
    integer, allocatable :: ib(:), cb(:)        !< output biases (segment by segment)
    integer, allocatable :: iq(:), cq(:)        !< process-noise variances
    integer, allocatable :: ir(:), cr(:)        !< measurement-noise variances
    integer, allocatable :: is(:), cs(:)        !< cross-covariances
    integer, allocatable :: id(:), cd(:)        !< output delays
    integer, allocatable :: iu(:), cu(:)        !< input delays
    integer, allocatable :: ik(:), ck(:)        !< gain K (block stab, filter_params = 'gain')
    integer, allocatable :: ip0(:), cp0(:)      !< the filter's initial covariance diagonal
    real(wp), allocatable :: wm(:), wx0(:), wb(:), wq(:), wr(:), ws(:), wd(:), wu(:), wk(:), wp0(:)
  end type param_map_t

contains

  !> Check the free flags and ties and build the map.
  subroutine param_map_create(l, isfree, tie, pm, status, msg)
    type(layout_t), intent(in) :: l
    integer, intent(in) :: isfree(:)
    type(tie_t), intent(in) :: tie
    type(param_map_t), intent(out) :: pm
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, col
    integer, allocatable :: act(:), acol(:)
    real(wp), allocatable :: aw(:)

    pm%l = l
    call check(l, isfree, tie, status, msg)
    if (status /= MLID_OK) return
    pm%tie = tie
    pm%ifree = free_indices(isfree)
    pm%nf = size(pm%ifree)
    ! moving entries: the free ones, then each term of a tie to a free one
    act = pm%ifree
    acol = [(k, k=1, pm%nf)]
    aw = [(1.0_wp, k=1, pm%nf)]
    do k = 1, size(tie%to)
      col = findloc(pm%ifree, tie%from(k), 1)
      if (col == 0) cycle               ! tied to a fixed entry: a constant
      act = [act, tie%to(k)]
      acol = [acol, col]
      aw = [aw, tie%scale(k)]
    end do
    call block(0, l%np, pm%im, pm%cm, pm%wm)
    call block(l%ox0, l%nx*l%nseg, pm%ix0, pm%cx0, pm%wx0)
    call block(l%obias, l%ny*l%nseg, pm%ib, pm%cb, pm%wb)
    call block(l%oq, l%nw, pm%iq, pm%cq, pm%wq)
    call block(l%or, l%ny, pm%ir, pm%cr, pm%wr)
    call block(l%os, l%nw*l%ny, pm%is, pm%cs, pm%ws)
    call block(l%odelay, l%ny, pm%id, pm%cd, pm%wd)
    call block(l%oudelay, l%nu, pm%iu, pm%cu, pm%wu)
    call block(l%ostab, l%nx*l%ny, pm%ik, pm%ck, pm%wk)
    call block(l%op0, l%nx, pm%ip0, pm%cp0, pm%wp0)

  contains

    subroutine block(offset, n, idx, cols, w)
      integer, intent(in) :: offset, n
      integer, allocatable, intent(out) :: idx(:), cols(:)
      real(wp), allocatable, intent(out) :: w(:)
      logical :: in(size(act))
      in = act > offset .and. act <= offset + n
      idx = pack(act, in) - offset
      cols = pack(acol, in)
      w = pack(aw, in)
    end subroutine block

  end subroutine param_map_create

  !> The theta indices of the free entries in the order of free: isfree(k) > 0
  !> is entry k's place among the free parameters, so that the report, the
  !> JSON and every table list them as the deck or script listed them.  Equal
  !> places keep theta order (flags of 1 give theta order; a manoeuvre's own
  !> copies of one free entry share its place).
  pure function free_indices(isfree) result(idx)
    integer, intent(in) :: isfree(:)
    integer, allocatable :: idx(:)
    integer :: k, j, key
    idx = pack([(k, k=1, size(isfree))], isfree > 0)
    do k = 2, size(idx)                  ! a stable insertion sort: free lists are short
      key = idx(k)
      j = k - 1
      do while (j >= 1)
        if (isfree(idx(j)) <= isfree(key)) exit
        idx(j + 1) = idx(j)
        j = j - 1
      end do
      idx(j + 1) = key
    end do
  end function free_indices

  !> The places of the free entries on several manoeuvres (map, seg:
  !> mlid_layout's manoeuvre_map): the shared ones keep theirs; manoeuvre k's
  !> own copies follow all of them, manoeuvre by manoeuvre, each in the order
  !> of free.  As python/mlid/model/maneuvers.py's Params does.
  pure function manoeuvre_places(isfree, map, seg) result(places)
    integer, intent(in) :: isfree(:), map(:), seg(:)
    integer :: places(size(map))
    places = isfree(map)
    where (places > 0 .and. seg > 0) places = places + seg*maxval(isfree)
  end function manoeuvre_places

  !> The map of one manoeuvre's sensitivities: only the free columns that
  !> can move segment iseg (its own initial state and biases, the model
  !> parameters the model reads there, used(k) for p(k), and the other
  !> blocks' entries), renumbered; cols(c) is new column c's old number.
  subroutine segment_map(pm, iseg, used, pk, cols)
    type(param_map_t), intent(in) :: pm
    integer, intent(in) :: iseg
    logical, intent(in) :: used(:)
    type(param_map_t), intent(out) :: pk
    integer, allocatable, intent(out) :: cols(:)
    logical :: km(size(pm%im)), kx0(size(pm%ix0)), kb(size(pm%ib)), keep(pm%nf)
    integer :: new(pm%nf), k

    km = used(pm%im)
    kx0 = (pm%ix0 - 1)/max(pm%l%nx, 1) + 1 == iseg
    kb = (pm%ib - 1)/max(pm%l%ny, 1) + 1 == iseg
    keep = .false.
    call mark(pm%cm, km)
    call mark(pm%cx0, kx0)
    call mark(pm%cb, kb)
    call mark([pm%cq, pm%cr, pm%cs, pm%cd, pm%cu, pm%ck, pm%cp0])
    cols = pack([(k, k=1, pm%nf)], keep)
    new = 0
    new(cols) = [(k, k=1, size(cols))]
    pk = pm                                    ! the other blocks' entries all stay
    pk%nf = size(cols)
    pk%ifree = pm%ifree(cols)
    call entries(pm%im, pm%cm, pm%wm, km, pk%im, pk%cm, pk%wm)
    call entries(pm%ix0, pm%cx0, pm%wx0, kx0, pk%ix0, pk%cx0, pk%wx0)
    call entries(pm%ib, pm%cb, pm%wb, kb, pk%ib, pk%cb, pk%wb)
    pk%cq = new(pm%cq)
    pk%cr = new(pm%cr)
    pk%cs = new(pm%cs)
    pk%cd = new(pm%cd)
    pk%cu = new(pm%cu)
    pk%ck = new(pm%ck)
    pk%cp0 = new(pm%cp0)

  contains

    !> keep the columns of the entries kept, or of all (a loop: ties repeat a column)
    subroutine mark(col, kept)
      integer, intent(in) :: col(:)
      logical, intent(in), optional :: kept(:)
      integer :: e
      do e = 1, size(col)
        if (present(kept)) then
          if (.not. kept(e)) cycle
        end if
        keep(col(e)) = .true.
      end do
    end subroutine mark

    subroutine entries(idx, col, w, kept, kidx, kcol, kw)
      integer, intent(in) :: idx(:), col(:)
      real(wp), intent(in) :: w(:)
      logical, intent(in) :: kept(:)
      integer, allocatable, intent(out) :: kidx(:), kcol(:)
      real(wp), allocatable, intent(out) :: kw(:)
      kidx = pack(idx, kept)
      kcol = new(pack(col, kept))
      kw = pack(w, kept)
    end subroutine entries

  end subroutine segment_map

  !> The free flags and the ties: each term names two entries; a tied entry
  !> is not free; a source is not itself tied (no chains, hence no cycles).
  subroutine check(l, isfree, tie, status, msg)
    type(layout_t), intent(in) :: l
    integer, intent(in) :: isfree(:)
    type(tie_t), intent(in) :: tie
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: i, k, j

    status = MLID_ERR_INPUT
    if (size(isfree) /= l%nth .or. size(tie%offset) /= l%nth .or. &
        size(tie%from) /= size(tie%to) .or. size(tie%scale) /= size(tie%to)) then
      write (msg, '(a,i0)') 'free flags and tie offsets must have nth entries, tie terms '// &
        'one source and scale each: nth = ', l%nth
      return
    end if
    if (any(isfree < 0)) then
      msg = 'free flags must be 0 (fixed) or a free parameter''s place in the order of free (> 0)'
      return
    end if
    do i = 1, size(tie%to)
      k = tie%to(i)
      j = tie%from(i)
      if (k < 1 .or. k > l%nth .or. j < 1 .or. j > l%nth) then
        write (msg, '(a,i0,a,i0)') 'parameter ', k, ' is tied to a parameter that does not exist: ', j
        return
      else if (j == k) then
        write (msg, '(a,i0,a)') 'parameter ', k, ' is tied to itself'
        return
      else if (isfree(k) > 0) then
        write (msg, '(a,i0,a)') 'parameter ', k, ' is both free and tied'
        return
      else if (any(tie%to == j)) then
        write (msg, '(a,i0,a,i0,a)') 'parameter ', k, ' is tied to ', j, &
          ' which is itself tied (a chain or a cycle of ties): tie to the free parameter'
        return
      end if
    end do
    status = MLID_OK
    msg = ''
  end subroutine check

  !> No ties on a vector of nth entries.
  pure function no_ties(nth) result(tie)
    integer, intent(in) :: nth
    type(tie_t) :: tie
    allocate (tie%to(0), tie%from(0), tie%scale(0), tie%offset(nth))
    tie%offset = 0.0_wp
  end function no_ties

  !> theta(k) := offset(k) + sum of its terms, for every tied entry.
  pure subroutine apply_ties(tie, theta)
    type(tie_t), intent(in) :: tie
    real(wp), intent(inout) :: theta(:)
    integer :: i
    do i = 1, size(tie%to)
      theta(tie%to(i)) = tie%offset(tie%to(i))
    end do
    do i = 1, size(tie%to)
      theta(tie%to(i)) = theta(tie%to(i)) + tie%scale(i)*theta(tie%from(i))
    end do
  end subroutine apply_ties

  !> Whether any input is delayed or its delay free.
  pure logical function input_delays(theta, pm)
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    input_delays = size(pm%iu) > 0 .or. &
                   any(theta(pm%l%oudelay + 1:pm%l%oudelay + pm%l%nu) /= 0.0_wp)
  end function input_delays

  !> Whether any output is delayed or its delay free.
  pure logical function output_delays(theta, pm)
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    output_delays = size(pm%id) > 0 .or. &
                    any(theta(pm%l%odelay + 1:pm%l%odelay + pm%l%ny) /= 0.0_wp)
  end function output_delays

  !> Whether the stabilized output error's gain (block stab) is set.
  pure logical function stabilized(theta, l)
    real(wp), intent(in) :: theta(:)
    type(layout_t), intent(in) :: l
    stabilized = any(theta(l%ostab + 1:l%op0) /= 0.0_wp)
  end function stabilized

  !> The ties of a flat interface: the first ntie terms (no more than given).
  pure function ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset) result(tie)
    integer, intent(in) :: ntie, tie_to(:), tie_from(:)
    real(wp), intent(in) :: tie_scale(:), tie_offset(:)
    type(tie_t) :: tie
    integer :: n
    n = max(0, min(ntie, size(tie_to), size(tie_from), size(tie_scale)))
    tie = tie_t(tie_to(1:n), tie_from(1:n), tie_scale(1:n), tie_offset)
  end function ties_of

end module mlid_params
